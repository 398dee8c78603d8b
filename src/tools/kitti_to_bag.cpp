// kitti_to_bag: writes a KITTI odometry or raw sequence to a rosbag with kitti2bag's topic and
// frame names. Usage: rosbag-free of a master; see --help.
#include <cstdint>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <ros/time.h>
#include <rosbag/exceptions.h>

#include "cli.h"
#include "tescalib/core/common/error.h"
#include "tescalib/core/common/geometry.h"
#include "tescalib/ros/kitti_bag_writer.h"

namespace {

using tescalib::cli::add;
using tescalib::cli::to;

const char* const kUsage =
    "usage: rosrun tescalib kitti_to_bag --in DIR[,DIR...] --out FILE.bag [OPTIONS]";
const char* const kDescription =
    "DIR: a KITTI odometry sequence (calib.txt, times.txt, image_2/, image_3/, velodyne/) or a "
    "KITTI raw drive folder (image_02/data, image_03/data, velodyne_points/data; calib_*.txt in "
    "it or in its parent).\n"
    "Several DIRs (one rig: the same calibration and image size) are written one after the "
    "other. A raw drive keeps its stamps and odometry stamps (from 0 s) are shifted to start at "
    "1317384000 s (ROS times must be positive), unless that would not start at least 1 s after "
    "the last frame written: then the DIR starts 1 s after it.\n"
    "Topics: /kitti/velo/pointcloud (velo_link; x y z intensity ring), "
    "/kitti/camera_color_{left,right}/{image_raw,camera_info} (P = the data's P2 / P3), "
    "/tf_static (base_link -> velo_link -> cameras).";

struct Args {
  std::string in, out;
  tescalib::KittiBagOptions options;
};

void addOptions(CLI::App* app, Args* a) {
  add(app, "--in", "DIR[,DIR...]", to(&a->in, tescalib::cli::text), "the sequences")->required();
  add(app, "--out", "FILE.bag", to(&a->out, tescalib::cli::text), "the bag")->required();
  add(
      app, "--max-frames", "N",
      [a](const std::string& v) {
        try {
          a->options.max_frames = tescalib::cli::atLeast(1)(v);
        } catch (const std::exception&) {
          throw CLI::ValidationError("--max-frames needs a whole number >= 1, not '" + v + "'");
        }
      },
      "at most the first N frames of each DIR (not of the whole bag)");
  add(
      app, "--like-kitti2bag", "0|1",
      [a](const std::string& v) {
        if (v != "0" && v != "1")
          throw CLI::ValidationError("--like-kitti2bag takes 0 or 1, not '" + v + "'");
        a->options.like_kitti2bag = v == "1";
      },
      "1: as kitti2bag's raw mode lays a bag out (imu_link above velo_link and the cameras, bgr8 "
      "images, x y z i clouds without ring), to check a pipeline against such bags");
  add(
      app, "--stamp-offset-ns", "N",
      [a](const std::string& v) {
        try {
          const int ns = tescalib::cli::toInt(v);
          if (ns < 0 || ns > 999999999) throw std::invalid_argument(v);
          a->options.stamp_offset_nsec = static_cast<uint32_t>(ns);
        } catch (const std::exception&) {
          throw CLI::ValidationError("--stamp-offset-ns needs a whole number 0-999999999, not '" +
                                     v + "'");
        }
      },
      "add N nanoseconds (0-999999999) to every stamp, so that they are not on the files' 0.1 s "
      "grid (tests of stamp handling)");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app(kDescription, "kitti_to_bag");
  tescalib::cli::setUp(&app, kUsage, "Options");
  Args args;
  addOptions(&app, &args);
  if (argc == 1) {  // no arguments at all: what the tool takes
    std::cout << app.help();
    return 2;
  }
  if (!tescalib::cli::parse(&app, argc, argv)) {
    std::cerr << "kitti_to_bag: --help lists the options\n";
    return 2;
  }
  const std::string& in = args.in;
  const std::string& out = args.out;
  const tescalib::KittiBagOptions& options = args.options;
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
