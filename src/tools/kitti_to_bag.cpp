// kitti_to_bag: writes a KITTI odometry or raw sequence to a rosbag with kitti2bag's topic and
// frame names. Usage: rosbag-free of a master; see --help.
#include <cstdlib>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <ros/time.h>
#include <rosbag/exceptions.h>

#include "cli.h"
#include "tescalib/core/common/error.h"
#include "tescalib/core/common/geometry.h"
#include "tescalib/ros/kitti_bag_writer.h"

namespace {
void usage() {
  std::cout << "usage: rosrun tescalib kitti_to_bag --in DIR[,DIR...] --out FILE.bag\n"
               "         [--max-frames N] [--like-kitti2bag 0|1] [--stamp-offset-ns N]\n"
               "  DIR: a KITTI odometry sequence (calib.txt, times.txt, image_2/, image_3/,\n"
               "       velodyne/) or a KITTI raw drive folder (image_02/data, image_03/data,\n"
               "       velodyne_points/data; calib_*.txt in it or in its parent).\n"
               "  Several DIRs (one rig: the same calibration and image size) are written one\n"
               "  after the other. A raw drive keeps its stamps and odometry stamps (from 0 s)\n"
               "  are shifted to start at 1317384000 s (ROS times must be positive), unless that\n"
               "  would not start at least 1 s after the last frame written: then the DIR starts\n"
               "  1 s after it.\n"
               "  Topics: /kitti/velo/pointcloud (velo_link; x y z intensity ring),\n"
               "          /kitti/camera_color_{left,right}/{image_raw,camera_info} (P = the\n"
               "          data's P2 / P3), /tf_static (base_link -> velo_link -> cameras)\n"
               "  --like-kitti2bag 1: as kitti2bag's raw mode lays a bag out (imu_link above\n"
               "  velo_link and the cameras, bgr8 images, x y z i clouds without ring), to check\n"
               "  a pipeline against such bags.\n"
               "  --max-frames N: at most the first N frames of each DIR (not of the whole bag).\n"
               "  --stamp-offset-ns N: add N nanoseconds (0-999999999) to every stamp, so that\n"
               "  they are not on the files' 0.1 s grid (tests of stamp handling).\n";
}
}  // namespace

int main(int argc, char** argv) {
  std::string in, out;
  tescalib::KittiBagOptions options;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::cerr << "kitti_to_bag: " << a << " needs a value\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--in")
      in = next();
    else if (a == "--out")
      out = next();
    else if (a == "--max-frames") {
      const std::string v = next();
      try {
        options.max_frames = tescalib::cli::toInt(v);
        if (options.max_frames < 1) throw std::invalid_argument(v);
      } catch (const std::exception&) {
        std::cerr << "kitti_to_bag: --max-frames needs a whole number >= 1, not '" << v << "'\n";
        return 2;
      }
    } else if (a == "--stamp-offset-ns") {
      const std::string v = next();
      try {
        const int ns = tescalib::cli::toInt(v);
        if (ns < 0 || ns > 999999999) throw std::invalid_argument(v);
        options.stamp_offset_nsec = static_cast<uint32_t>(ns);
      } catch (const std::exception&) {
        std::cerr << "kitti_to_bag: --stamp-offset-ns needs a whole number 0-999999999, not '" << v
                  << "'\n";
        return 2;
      }
    } else if (a == "--like-kitti2bag") {
      const std::string v = next();
      if (v != "0" && v != "1") {
        std::cerr << "kitti_to_bag: --like-kitti2bag takes 0 or 1, not '" << v << "'\n";
        return 2;
      }
      options.like_kitti2bag = v == "1";
    } else if (a == "-h" || a == "--help") {
      usage();
      return 0;
    } else {
      std::cerr << "kitti_to_bag: unknown argument " << a << " (--help lists the options)\n";
      return 2;
    }
  }
  if (in.empty() || out.empty()) {
    if (argc == 1) {  // no arguments at all: what the tool takes
      usage();
      return 2;
    }
    std::cerr << "kitti_to_bag: --in and --out are required (--help lists the options)\n";
    return 2;
  }
  ros::Time::init();
  try {
    const std::vector<std::string> dirs = tescalib::cli::splitList(in);
    if (dirs.empty()) {
      std::cerr << "kitti_to_bag: --in names no folder\n";
      return 2;
    }
    // One bag holds one rig: openSequences refuses folders of different calibrations or sizes.
    const auto seqs = tescalib::openSequences(dirs);
    std::vector<const tescalib::KittiSequence*> ptrs;
    for (const auto& seq : seqs) {
      ptrs.push_back(seq.get());
      std::cout << "kitti_to_bag: " << seq->size() << " frames from " << seq->dir() << " ("
                << (seq->layout() == tescalib::KittiLayout::kOdometry ? "odometry" : "raw")
                << " layout, " << seq->rig().left.width << "x" << seq->rig().left.height << ")\n";
    }
    tescalib::writeKittiBag(ptrs, out, options, [](size_t i, size_t n) {
      if (i == n || i % 50 == 0) std::cout << "  " << i << "/" << n << " frames\n";
    });
    std::cout << "kitti_to_bag: wrote " << out << "\n";
  } catch (const tescalib::DataError& e) {
    std::cerr << "kitti_to_bag: " << e.what() << "\n";
    return 1;
  } catch (const rosbag::BagException& e) {
    std::cerr << "kitti_to_bag: cannot write bag " << out << ": " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {  // anything else (OpenCV, ros::Time): a message, not abort
    std::cerr << "kitti_to_bag: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
