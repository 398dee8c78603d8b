// tescalib_simulate: writes a generated driving sequence with exact ground truth in the KITTI
// odometry layout (see include/tescalib/core/sim/simulator.h and --help).
#include <chrono>
#include <iostream>
#include <limits>
#include <string>

#include "tescalib/core/common/error.h"
#include "tescalib/core/io/kitti_reader.h"
#include "tescalib/core/sim/simulator.h"

namespace {

void usage() {
  std::cout << "usage: rosrun tescalib tescalib_simulate --scenario urban|residential|highway\n"
               "         --frames N --seed S --out DIR [--calib FILE]\n"
               "         [--noise default|none|high] [--size WxH] [--threads T]\n"
               "         [--lidar-sweep 0|1]\n"
               "  Writes a KITTI odometry sequence to DIR: calib.txt (P0-P3, Tr: the ground\n"
               "  truth), times.txt (10 Hz), image_2/ image_3/ (8-bit RGB PNG), velodyne/*.bin\n"
               "  (HDL-64E-like, KITTI ring order), poses.txt (cam0 poses, KITTI convention),\n"
               "  sim_info.txt.\n"
               "  --calib FILE  KITTI calib.txt whose P2, P3 and Tr become the rig (default:\n"
               "                KITTI-like fx 718.856, 0.54 m baseline, the 2011_09_30 Tr)\n"
               "  --noise       sensor noise preset (default: LiDAR 2 cm range, 0.03 deg\n"
               "                direction, image sigma 2 grey levels; high: 5 cm, 0.1 deg, 6;\n"
               "                none)\n"
               "  --size WxH    image size (default 1241x376); the intrinsics (P2, P3) stay as\n"
               "                they are: a smaller size crops the top-left of the view, it does\n"
               "                not scale\n"
               "  --threads T   worker threads (default: all cores); the output does not depend\n"
               "                on it\n"
               "  --lidar-sweep 1  sweep each scan over its 0.1 s revolution (clockwise, forward\n"
               "                at the frame's stamp) as a raw driver delivers it: motion-skewed\n"
               "                scans to de-skew (default 0: every beam from the pose at the\n"
               "                stamp)\n"
               "  The same arguments give the same bytes.\n";
}

}  // namespace

int main(int argc, char** argv) {
  tescalib::SimOptions options;
  std::string out, calib;
  bool have_scenario = false, have_frames = false, have_seed = false;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto next = [&]() -> std::string {
        if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
        return argv[++i];
      };
      // A whole number; `max_int` keeps it within an int (the options that are ints).
      auto integer = [&](const std::string& v, bool max_int = true) -> long long {
        size_t used = 0;
        long long x = 0;
        try {
          x = std::stoll(v, &used);
        } catch (const std::out_of_range&) {
          throw std::invalid_argument(a + ": '" + v + "' is out of range");
        }
        if (used != v.size()) throw std::invalid_argument(a + ": '" + v + "' is not an integer");
        if (max_int && (x > std::numeric_limits<int>::max() || x < std::numeric_limits<int>::min()))
          throw std::invalid_argument(a + ": '" + v + "' is out of range");
        return x;
      };
      if (a == "--scenario") {
        const std::string v = next();
        if (!tescalib::sim::parseScenario(v, &options.scenario))
          throw std::invalid_argument("--scenario must be urban, residential or highway, not '" +
                                      v + "'");
        have_scenario = true;
      } else if (a == "--frames") {
        options.frames = static_cast<int>(integer(next()));
        have_frames = true;
      } else if (a == "--seed") {
        const long long s = integer(next(), false);
        if (s < 0) throw std::invalid_argument("--seed must be non-negative");
        options.seed = static_cast<uint64_t>(s);
        have_seed = true;
      } else if (a == "--out") {
        out = next();
      } else if (a == "--calib") {
        calib = next();
      } else if (a == "--noise") {
        const std::string v = next();
        if (!tescalib::parseNoiseLevel(v, &options.noise))
          throw std::invalid_argument("--noise must be default, none or high, not '" + v + "'");
      } else if (a == "--size") {
        const std::string v = next();
        const auto x = v.find('x');
        if (x == std::string::npos) throw std::invalid_argument("--size must look like 1241x376");
        options.width = static_cast<int>(integer(v.substr(0, x)));
        options.height = static_cast<int>(integer(v.substr(x + 1)));
      } else if (a == "--threads") {
        options.threads = static_cast<int>(integer(next()));
      } else if (a == "--lidar-sweep") {
        const long long v = integer(next());
        if (v != 0 && v != 1) throw std::invalid_argument("--lidar-sweep must be 0 or 1");
        options.lidar_sweep = v == 1;
      } else if (a == "-h" || a == "--help") {
        usage();
        return 0;
      } else {
        throw std::invalid_argument("unknown argument " + a);
      }
    }
    if (!have_scenario || !have_frames || !have_seed || out.empty())
      throw std::invalid_argument("--scenario, --frames, --seed and --out are required");
  } catch (const std::exception& e) {
    std::cerr << "tescalib_simulate: " << e.what() << " (--help lists the options)\n";
    return 2;
  }
  try {
    if (!calib.empty()) options.calib = tescalib::readKittiOdometryCalib(calib);
    const auto start = std::chrono::steady_clock::now();
    tescalib::simulateSequence(options, out);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::cout << "tescalib_simulate: wrote " << options.frames << " frames of "
              << tescalib::sim::scenarioName(options.scenario) << " (seed " << options.seed
              << ") to " << out << " in " << seconds << " s\n";
  } catch (const tescalib::DataError& e) {
    std::cerr << "tescalib_simulate: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
