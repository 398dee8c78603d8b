// The core library must stay ROS-free: no file under include/tescalib/core or src/core may
// include a ROS header.
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include <gtest/gtest.h>

namespace fs = std::filesystem;

TEST(CoreIsRosFree, NoRosIncludes) {
  const std::regex ros_include(
      R"(#\s*include\s*[<"](ros/|nodelet/|tf2_ros/|tf2_msgs/|sensor_msgs/|geometry_msgs/|std_msgs/|cv_bridge/|pcl_conversions/|rosbag/|message_filters/|image_transport/|diagnostic_updater/|pluginlib/|tescalib/ros/))");
  int files = 0;
  for (const char* sub : {"include/tescalib/core", "src/core"}) {
    const fs::path dir = fs::path(TESCALIB_SOURCE_DIR) / sub;
    ASSERT_TRUE(fs::is_directory(dir)) << dir;
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
      if (!e.is_regular_file()) continue;
      ++files;
      std::ifstream in(e.path());
      std::string line;
      int n = 0;
      while (std::getline(in, line)) {
        ++n;
        EXPECT_FALSE(std::regex_search(line, ros_include))
            << e.path().string() << ":" << n << " includes a ROS header: " << line;
      }
    }
  }
  EXPECT_GT(files, 3);
}

TEST(CoreIsRosFree, CheckerCatchesRosInclude) {
  // The regex above must be able to fail: a ROS include is matched.
  const std::regex ros_include(R"(#\s*include\s*[<"](ros/|sensor_msgs/))");
  EXPECT_TRUE(std::regex_search(std::string("#include <ros/ros.h>"), ros_include));
  EXPECT_FALSE(std::regex_search(std::string("#include <Eigen/Core>"), ros_include));
}
