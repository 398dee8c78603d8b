// tescalib_simulate: writes a generated driving sequence with exact ground truth in the KITTI
// odometry layout (see include/tescalib/core/sim/simulator.h and --help).
#include <chrono>
#include <cstdint>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli.h"
#include "tescalib/core/common/error.h"
#include "tescalib/core/io/kitti_reader.h"
#include "tescalib/core/sim/simulator.h"

namespace {

const char* const kUsage =
    "usage: rosrun tescalib tescalib_simulate --scenario urban|residential|highway\n"
    "         --frames N --seed S --out DIR [OPTIONS]";
const char* const kDescription =
    "Writes a KITTI odometry sequence to DIR: calib.txt (P0-P3, Tr: the ground truth), times.txt "
    "(10 Hz), image_2/ image_3/ (8-bit RGB PNG), velodyne/*.bin (HDL-64E-like, KITTI ring "
    "order), poses.txt (cam0 poses, KITTI convention), sim_info.txt.";
const char* const kFooter = "The same arguments give the same bytes.";

struct Args {
  tescalib::SimOptions options;
  std::string out, calib, rig = "default";
  std::vector<std::string> realism_set;  ///< --realism-set's assignments, applied after --realism
  bool size_given = false;
};

/// A whole number >= 0 of up to 63 bits (a seed).
uint64_t toNonNegativeLong(const std::string& v) {
  size_t used = 0;
  const long long x = std::stoll(v, &used);
  if (used != v.size() || x < 0) throw std::invalid_argument(v);
  return static_cast<uint64_t>(x);
}

/// --extrinsic-step AT_S,ROT_DEG,TRANS_M[,lidar|stereo].
void setStep(const std::string& v, tescalib::ExtrinsicStep* step) {
  std::vector<std::string> parts;
  std::stringstream in(v);
  for (std::string p; std::getline(in, p, ',');) parts.push_back(p);
  const auto bad = [&v]() {
    return CLI::ValidationError(
        "--extrinsic-step wants AT_S,ROT_DEG,TRANS_M[,lidar|stereo] "
        "(AT_S >= 0 s, 0-90 deg, 0-1 m), not '" +
        v + "'");
  };
  if (parts.size() < 3 || parts.size() > 4) throw bad();
  try {
    step->at_s = tescalib::cli::toDouble(parts[0]);
    step->rot_deg = tescalib::cli::toDouble(parts[1]);
    step->trans_m = tescalib::cli::toDouble(parts[2]);
  } catch (const std::exception&) {
    throw bad();
  }
  if (parts.size() == 4 && parts[3] != "lidar" && parts[3] != "stereo") throw bad();
  step->stereo = parts.size() == 4 && parts[3] == "stereo";
  if (!(step->at_s >= 0) || !(step->rot_deg >= 0 && step->rot_deg <= 90) ||
      !(step->trans_m >= 0 && step->trans_m <= 1))
    throw bad();
}

/// --size WxH: the image size.
void setSize(const std::string& v, tescalib::SimOptions* o) {
  const auto x = v.find('x');
  if (x == std::string::npos) throw CLI::ValidationError("--size must look like 1241x376");
  o->width = tescalib::cli::toInt(v.substr(0, x));
  o->height = tescalib::cli::toInt(v.substr(x + 1));
}

/// The drive: scenario, length, seed and where it goes (all required).
void addDriveOptions(CLI::App* app, Args* a) {
  using tescalib::cli::add;
  using tescalib::cli::to;
  const char* g = "Drive";
  add(
      app, "--scenario", "NAME",
      [a](const std::string& v) {
        if (!tescalib::sim::parseScenario(v, &a->options.scenario))
          throw CLI::ValidationError("--scenario must be urban, residential or highway, not '" + v +
                                     "'");
      },
      "urban, residential or highway")
      ->group(g)
      ->required();
  add(app, "--frames", "N", to(&a->options.frames, tescalib::cli::toInt), "frames (10 Hz)")
      ->group(g)
      ->required();
  add(app, "--every", "K", to(&a->options.write_every, tescalib::cli::toInt),
      "write only every Kth frame (default 1): the same drive at 10/K Hz, numbered 0, 1, 2, "
      "... with their own stamps (5: one frame per keyframe, a fifth of the rendering)")
      ->group(g);
  add(app, "--seed", "S", to(&a->options.seed, toNonNegativeLong),
      "world, trajectory and noise seed (>= 0)")
      ->group(g)
      ->required();
  add(app, "--out", "DIR", to(&a->out, tescalib::cli::text), "the sequence's folder")
      ->group(g)
      ->required();
}

/// The rig and its sensors.
void addSensorOptions(CLI::App* app, Args* a) {
  using tescalib::cli::add;
  using tescalib::cli::to;
  const char* g = "Sensors";
  add(
      app, "--rig", "default|random",
      [a](const std::string& v) {
        if (v != "default" && v != "random")
          throw CLI::ValidationError("--rig must be default or random, not '" + v + "'");
        a->rig = v;
      },
      "default: KITTI-like (fx 718.856, 1241x376, 0.54 m baseline, the right camera on the left "
      "camera's x axis, the 2011_09_30 Tr); random: drawn from --seed (baseline 0.12-0.6 m, "
      "focal length, image size, principal point, the right camera a few mm off the x axis as "
      "real rectified pairs are, the LiDAR anywhere within 1 m of the camera in any driver's "
      "axis convention); sim_info.txt records it")
      ->group(g);
  add(app, "--calib", "FILE", to(&a->calib, tescalib::cli::text),
      "KITTI calib.txt whose P2, P3 and Tr become the rig (instead of --rig)")
      ->group(g);
  add(
      app, "--noise", "LEVEL",
      [a](const std::string& v) {
        if (!tescalib::parseNoiseLevel(v, &a->options.noise))
          throw CLI::ValidationError("--noise must be default, none or high, not '" + v + "'");
      },
      "sensor noise preset: default (LiDAR 2 cm range, 0.03 deg direction, image sigma 2 grey "
      "levels), high (5 cm, 0.1 deg, 6) or none")
      ->group(g);
  add(
      app, "--size", "WxH",
      [a](const std::string& v) {
        setSize(v, &a->options);
        a->size_given = true;
      },
      "image size (default 1241x376); the intrinsics (P2, P3) stay as they are: a smaller size "
      "crops the top-left of the view, it does not scale")
      ->group(g);
  add(app, "--lidar-sweep", "0|1", to(&a->options.lidar_sweep, tescalib::cli::toSwitch),
      "1: sweep each scan over its 0.1 s revolution (clockwise, forward at the frame's stamp) as "
      "a raw driver delivers it: motion-skewed scans to de-skew (default 0: every beam from the "
      "pose at the stamp)")
      ->group(g);
  add(
      app, "--extrinsic-step", "AT_S,ROT_DEG,TRANS_M[,lidar|stereo]",
      [a](const std::string& v) { setStep(v, &a->options.step); },
      "the true T_cam_lidar (lidar, the default) or T_right_left (stereo) changes at AT_S s of "
      "the drive by exactly ROT_DEG and TRANS_M in a random direction (from the seed); "
      "calib.txt holds the truth before it, calib_after_step.txt the truth after it")
      ->group(g);
  add(app, "--threads", "T", to(&a->options.threads, tescalib::cli::toInt),
      "worker threads (default: all cores); the output does not depend on it")
      ->group(g);
}

/// Real sensors' errors: the preset and the changes to it.
void addRealismOptions(CLI::App* app, Args* a) {
  using tescalib::cli::add;
  const char* g = "Real sensors' errors";
  add(
      app, "--realism", "none|kitti",
      [a](const std::string& v) {
        if (!tescalib::sim::RealismSizes::preset(v, &a->options.realism))
          throw CLI::ValidationError("--realism must be none or kitti, not '" + v + "'");
        a->options.realism_name = v;
      },
      "none (default): clean sensors; kitti: the right camera's residual rotation and f x B "
      "error, residual lens distortion, a softer right camera, vignetting, per-laser range "
      "offsets and elevation errors, a range scale, mixed pixels, a LiDAR-camera time offset and "
      "low-texture asphalt, sized like the real KITTI recordings; each drive draws its values "
      "from --seed (sim_info.txt lists them)")
      ->group(g);
  add(
      app, "--realism-set", "KEY=VALUE[,...]",
      [a](const std::string& v) { a->realism_set.push_back(v); },
      "sizes one source (after --realism): right_rotation_deg, baseline_scale, lens_k1 (rms), "
      "right_blur_px, vignetting, laser_range_offset_m, laser_elevation_deg, range_scale (rms), "
      "mixed_pixel_fraction, lidar_time_offset_s (rms), asphalt_texture (1: clean); 0 switches "
      "a source off")
      ->group(g);
}

bool parse(int argc, char** argv, Args* a) {
  CLI::App app(kDescription, "tescalib_simulate");
  tescalib::cli::setUp(&app, kUsage, "Drive");
  app.footer(kFooter);
  addDriveOptions(&app, a);
  addSensorOptions(&app, a);
  addRealismOptions(&app, a);
  if (!tescalib::cli::parse(&app, argc, argv)) return false;
  for (const std::string& v : a->realism_set) {
    const std::string problem = a->options.realism.set(v);
    if (!problem.empty()) {
      std::cerr << "tescalib_simulate: --realism-set: " << problem << "\n";
      return false;
    }
    a->options.realism_name += " " + v;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  Args args;
  if (!parse(argc, argv, &args)) {
    std::cerr << "tescalib_simulate: --help lists the options\n";
    return 2;
  }
  tescalib::SimOptions& options = args.options;
  if (args.rig == "random" && (!args.calib.empty() || args.size_given)) {
    std::cerr << "tescalib_simulate: --rig random draws the calibration and the image size; "
                 "leave out --calib and --size\n";
    return 2;
  }
  try {
    if (args.rig == "random") tescalib::useRandomRig(options.seed, &options);
    if (!args.calib.empty()) {
      options.calib = tescalib::readKittiOdometryCalib(args.calib);
      options.rig_source = "calib " + args.calib;
    }
    const auto start = std::chrono::steady_clock::now();
    tescalib::simulateSequence(options, args.out);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::cout << "tescalib_simulate: wrote " << options.writtenFrames() << " frames of "
              << tescalib::sim::scenarioName(options.scenario) << " (seed " << options.seed
              << ", rig " << options.rig_source << ", realism " << options.realism_name << ", "
              << options.width << "x" << options.height << ") to " << args.out << " in " << seconds
              << " s\n";
  } catch (const tescalib::DataError& e) {
    std::cerr << "tescalib_simulate: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
