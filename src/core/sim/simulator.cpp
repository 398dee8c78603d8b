#include "tescalib/core/sim/simulator.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <mutex>
#include <random>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "tescalib/core/common/error.h"
#include "tescalib/core/common/geometry.h"
#include "tescalib/core/common/parallel.h"
#include "tescalib/core/sim/scene_culling.h"
#include "tescalib/core/sim/simulator_camera.h"
#include "tescalib/core/sim/simulator_lidar.h"
#include "tescalib/core/sim/simulator_random.h"
#include "tescalib/core/sim/simulator_trajectory.h"

namespace fs = std::filesystem;

namespace tescalib {
namespace {

constexpr double kFrameRate = 10.0;
constexpr double kMaxSpeed = 14.0;      // m/s, bounds the route length
constexpr double kRouteBehind = 100.0;  // m of world behind the start
constexpr double kRouteAhead = 250.0;   // m of world beyond the last frame
constexpr float kCameraRange = 250.f;   // m; primitives beyond are not drawn
constexpr float kShadowRadius = 200.f;  // m; primitives within cast shadows

std::string frameName(int i) {
  char name[16];
  std::snprintf(name, sizeof(name), "%06d", i);
  return name;
}

void writeRow(std::ostream& out, const Eigen::Isometry3d& T) {
  const Eigen::Matrix<double, 3, 4> M = T.matrix().topRows<3>();
  char buf[32];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) {
      std::snprintf(buf, sizeof(buf), "%.12e", M(r, c));
      out << (r == 0 && c == 0 ? "" : " ") << buf;
    }
  out << "\n";
}

std::string yamlList(const Eigen::Isometry3d& T) {
  std::ostringstream s;
  s << std::setprecision(10) << "[";
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) s << (r == 0 && c == 0 ? "" : ", ") << T.matrix()(r, c);
  s << "]";
  return s.str();
}

void validate(const SimOptions& o) {
  auto fail = [](const std::string& what) { throw DataError("tescalib_simulate: " + what); };
  if (o.frames < 1 || o.frames > 1000000)
    fail("frames must be between 1 and 1000000 (got " + std::to_string(o.frames) + ")");
  if (o.write_every < 1 || o.write_every > o.frames)
    fail("--every must be between 1 and the number of frames (got " +
         std::to_string(o.write_every) + ")");
  if (o.width < 32 || o.height < 32 || o.width > 8192 || o.height > 8192)
    fail("image size " + std::to_string(o.width) + "x" + std::to_string(o.height) +
         " is out of range (32..8192 px)");
  if (!(o.left_gain > 0) || !(o.right_gain > 0)) fail("camera gains must be positive");
  const Eigen::Matrix3d K2 = o.calib.P[2].leftCols<3>(), K3 = o.calib.P[3].leftCols<3>();
  if (!(K2(0, 0) > 0) || !(K2(1, 1) > 0)) fail("calibration P2 has a non-positive focal length");
  if ((K2 - K3).cwiseAbs().maxCoeff() > 1e-6 * K2(0, 0))
    fail("calibration P2 and P3 have different intrinsics; a rectified pair shares one K");
  const Eigen::Matrix3d R = o.calib.Tr.leftCols<3>();
  if ((R * R.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-3)
    fail("calibration Tr is not a rotation (R R^T differs from I by more than 1e-3)");
  if (o.calib.Tr.col(3).norm() > 5.0) fail("calibration Tr puts the LiDAR more than 5 m from cam0");
  const double baseline = (K2.inverse() * (o.calib.P[3].col(3) - o.calib.P[2].col(3))).norm();
  if (baseline < 0.01) fail("calibration P2/P3 give a baseline below 1 cm");
  const ExtrinsicStep& st = o.step;
  if (st.active() && !(st.rot_deg >= 0 && st.rot_deg <= 90 && st.trans_m >= 0 && st.trans_m <= 1))
    fail("the extrinsic step's rotation must be 0-90 deg and its translation 0-1 m");
  if (st.active() && st.stereo &&
      (o.realism.right_rotation_deg > 0 || o.realism.baseline_scale > 0))
    fail(
        "a stereo extrinsic step and the realism's right camera errors (right_rotation_deg, "
        "baseline_scale) cannot be combined; set those two to 0");
}

}  // namespace

std::string noiseLevelName(NoiseLevel n) {
  switch (n) {
    case NoiseLevel::kNone:
      return "none";
    case NoiseLevel::kDefault:
      return "default";
    case NoiseLevel::kHigh:
      return "high";
  }
  return "unknown";
}

bool parseNoiseLevel(const std::string& name, NoiseLevel* n) {
  for (NoiseLevel c : {NoiseLevel::kNone, NoiseLevel::kDefault, NoiseLevel::kHigh})
    if (name == noiseLevelName(c)) {
      *n = c;
      return true;
    }
  return false;
}

SimNoise SimNoise::forLevel(NoiseLevel level) {
  SimNoise n;
  switch (level) {
    case NoiseLevel::kNone:
      n.lidar_range_sigma_m = 0.0;
      n.lidar_direction_sigma_deg = 0.0;
      n.lidar_intensity_sigma = 0.0;
      n.image_sigma = 0.0;
      break;
    case NoiseLevel::kDefault:
      break;
    case NoiseLevel::kHigh:
      n.lidar_range_sigma_m = 0.05;
      n.lidar_direction_sigma_deg = 0.1;
      n.lidar_intensity_sigma = 0.03;
      n.image_sigma = 6.0;
      break;
  }
  return n;
}

KittiOdometryCalib defaultSimCalib() {
  KittiOdometryCalib c;
  const double fx = 718.856, cx = 607.1928, cy = 185.2157;
  Eigen::Matrix<double, 3, 4> P;
  P << fx, 0, cx, 0, 0, fx, cy, 0, 0, 0, 1, 0;
  const double cam2_x = 0.06, baseline = 0.54;  // cam2 6 cm left of cam0, like KITTI
  for (int i = 0; i < 4; ++i) c.P[i] = P;
  c.P[1](0, 3) = -fx * baseline;
  c.P[2](0, 3) = fx * cam2_x;
  c.P[3](0, 3) = fx * (cam2_x - baseline);
  // Tr (velodyne -> rectified cam0) of the 2011_09_30 recordings (KITTI odometry 04-10).
  c.Tr << -1.857739385241e-03, -9.999659513510e-01, -8.039975204516e-03, -4.784029760483e-03,
      -6.481465826011e-03, 8.051860151134e-03, -9.999466081774e-01, -7.337429464231e-02,
      9.999773098287e-01, -1.805528627661e-03, -6.496203536139e-03, -3.339968064433e-01;
  return c;
}

namespace {

/// `calib` with the right camera at `T_right_left` from the left one (P3's last column and
/// R_right_left).
KittiOdometryCalib withRightLeft(const KittiOdometryCalib& calib,
                                 const Eigen::Isometry3d& T_right_left) {
  KittiOdometryCalib c = calib;
  const Eigen::Matrix3d K2_inv = calib.P[2].leftCols<3>().inverse();
  c.R_right_left = T_right_left.linear();
  c.P[3].col(3) =
      calib.P[3].leftCols<3>() * (T_right_left.translation() + K2_inv * calib.P[2].col(3));
  return c;
}

/// The calibration after `step` of `calib` (whose rig is `rig`), and that rig.
KittiOdometryCalib stepCalib(const KittiOdometryCalib& calib, const StereoRig& rig,
                             const ExtrinsicStep& step, uint64_t seed, StereoRig* after) {
  std::mt19937_64 rng(sim::subSeed(seed, 0x5e9));
  const Vector6d delta = randomPerturbation(step.rot_deg / kDegPerRad, step.trans_m, rng);
  KittiOdometryCalib c = calib;
  *after = rig;
  const Eigen::Matrix3d K2_inv = calib.P[2].leftCols<3>().inverse();
  if (step.stereo) {
    after->T_right_left = perturb(rig.T_right_left, delta);
    c = withRightLeft(calib, after->T_right_left);
  } else {
    after->T_cam_lidar = perturb(rig.T_cam_lidar, delta);
    Eigen::Isometry3d T_cam0_cam2 = Eigen::Isometry3d::Identity();
    T_cam0_cam2.translation() = -K2_inv * calib.P[2].col(3);
    c.Tr = (T_cam0_cam2 * after->T_cam_lidar).matrix().topRows<3>();
  }
  return c;
}

}  // namespace

struct Simulator::Impl {
  std::unique_ptr<sim::VehicleTrajectory> trajectory;
  Eigen::Isometry3d T_cam0_lidar;  ///< from Tr
  Eigen::Isometry3d T_cam2_lidar;  ///< ground truth as the reader recovers it
  Eigen::Isometry3d T_cam3_lidar;
  /// After SimOptions::step (the same as before without one).
  Eigen::Isometry3d T_cam2_lidar_after, T_cam3_lidar_after;
  StereoRig rig_after;
  KittiOdometryCalib calib_after;
  bool after(double t, const ExtrinsicStep& step) const { return step.active() && t >= step.at_s; }
  sim::LidarModel lidar = sim::LidarModel::hdl64e();
  sim::LidarNoise lidar_noise;
  sim::RealismDraw realism;
  StereoRig true_rig;
  KittiOdometryCalib true_calib;
};

Simulator::Simulator(const SimOptions& options)
    : options_(options), impl_(std::make_unique<Impl>()) {
  validate(options_);
  rig_ = rigFromOdometryCalib(options_.calib);
  rig_.left.width = rig_.right.width = options_.width;
  rig_.left.height = rig_.right.height = options_.height;
  impl_->realism = sim::drawRealism(options_.realism, options_.seed,
                                    static_cast<int>(impl_->lidar.elevation_deg.size()));
  impl_->true_rig = rig_;
  impl_->true_rig.T_right_left = impl_->realism.trueRightLeft(rig_.T_right_left);
  impl_->true_calib = impl_->realism.movesRightCamera()
                          ? withRightLeft(options_.calib, impl_->true_rig.T_right_left)
                          : options_.calib;
  impl_->T_cam2_lidar = rig_.T_cam_lidar;
  impl_->T_cam3_lidar = impl_->true_rig.T_right_left * rig_.T_cam_lidar;
  // cam0 = cam2 shifted back by K^-1 P2[:,3] (the reader's definition of cam2).
  Eigen::Isometry3d T_cam0_cam2 = Eigen::Isometry3d::Identity();
  T_cam0_cam2.translation() =
      -options_.calib.P[2].leftCols<3>().inverse() * options_.calib.P[2].col(3);
  impl_->T_cam0_lidar = T_cam0_cam2 * impl_->T_cam2_lidar;
  impl_->rig_after = rig_;
  impl_->calib_after = options_.calib;
  if (options_.step.active())
    impl_->calib_after =
        stepCalib(options_.calib, rig_, options_.step, options_.seed, &impl_->rig_after);
  impl_->T_cam2_lidar_after = impl_->rig_after.T_cam_lidar;
  impl_->T_cam3_lidar_after = impl_->rig_after.T_right_left * impl_->rig_after.T_cam_lidar;
  const double route = kMaxSpeed / kFrameRate * (options_.frames - 1);
  world_ = std::make_unique<sim::SceneWorld>(
      sim::buildScene(options_.scenario, options_.seed, -kRouteBehind, route + kRouteAhead));
  impl_->trajectory = std::make_unique<sim::VehicleTrajectory>(
      *world_->road, world_->lane_offset, options_.seed, sim::kVehicleFrameHeight);
  const SimNoise n = noise();
  impl_->lidar_noise.range_sigma = n.lidar_range_sigma_m;
  impl_->lidar_noise.direction_sigma_rad = n.lidar_direction_sigma_deg * M_PI / 180.0;
  impl_->lidar_noise.intensity_sigma = n.lidar_intensity_sigma;
  const sim::RealismDraw& r = impl_->realism;
  impl_->lidar_noise.laser_range_offset_m = r.laser_range_offset_m;
  impl_->lidar_noise.laser_elevation_rad = r.laser_elevation_rad;
  impl_->lidar_noise.range_scale = r.range_scale;
  impl_->lidar_noise.mixed_pixel_fraction = r.mixed_pixel_fraction;
  world_->ground.asphalt_texture = static_cast<float>(r.asphalt_texture);
}

const sim::RealismDraw& Simulator::realism() const { return impl_->realism; }
const StereoRig& Simulator::trueRig() const { return impl_->true_rig; }
const KittiOdometryCalib& Simulator::trueCalib() const { return impl_->true_calib; }

Simulator::~Simulator() = default;

Eigen::Isometry3d Simulator::worldFromLidar(int i) const { return worldFromLidarAt(stamp(i)); }

Eigen::Isometry3d Simulator::worldFromVehicleAt(double t) const {
  return impl_->trajectory->worldFromLidar(t);
}

Eigen::Isometry3d Simulator::worldFromLidarAt(double t) const {
  // After a LiDAR step the cameras stay on the vehicle where they were and the LiDAR moves.
  if (impl_->after(t, options_.step) && !options_.step.stereo)
    return worldFromVehicleAt(t) * options_.T_vehicle_lidar * impl_->T_cam2_lidar.inverse() *
           impl_->T_cam2_lidar_after;
  return worldFromVehicleAt(t) * options_.T_vehicle_lidar;
}

const StereoRig& Simulator::rigAfterStep() const { return impl_->rig_after; }
const KittiOdometryCalib& Simulator::calibAfterStep() const { return impl_->calib_after; }

void useRandomRig(uint64_t seed, SimOptions* options) {
  const sim::SimRig rig = sim::randomSimRig(seed);
  options->calib = rig.calib;
  options->width = rig.width;
  options->height = rig.height;
  options->T_vehicle_lidar = rig.T_vehicle_lidar;
  options->rig_source = "random";
}

Eigen::Isometry3d Simulator::cam0Pose(int i) const {
  // Where the LiDAR sits without a step: the cameras stay there relative to it through a step.
  const auto unstepped = [this](int k) {
    return worldFromVehicleAt(stamp(k)) * options_.T_vehicle_lidar;
  };
  const Eigen::Isometry3d lidar_cam0 = impl_->T_cam0_lidar.inverse();
  const Eigen::Isometry3d w0 = unstepped(0) * lidar_cam0;
  return w0.inverse() * (unstepped(i) * lidar_cam0);
}

LidarScan Simulator::renderScan(int i, int threads) const {
  const int t = resolveThreads(threads > 0 ? threads : options_.threads);
  const uint64_t seed = sim::subSeed(options_.seed, 4 * uint64_t(i) + 3);
  // The scan stamped stamp(i) is taken lidar_time_offset_s after the cameras' trigger.
  const double t0 = stamp(i) + impl_->realism.lidar_time_offset_s;
  if (options_.lidar_sweep) {
    return sim::simulateSweptLidarScan(
        *world_, [&](double dt) { return worldFromLidarAt(t0 + dt); }, impl_->lidar,
        impl_->lidar_noise, seed, t);
  }
  return sim::simulateLidarScan(*world_, worldFromLidarAt(t0), impl_->lidar, impl_->lidar_noise,
                                seed, t);
}

Frame Simulator::renderFrame(int i, int threads) const {
  const int t = resolveThreads(threads > 0 ? threads : options_.threads);
  const Eigen::Isometry3d T_wl = worldFromLidar(i);
  const sim::SunShadowGrid shadows(world_->prims, world_->sun, T_wl.translation().cast<float>(),
                                   kShadowRadius);
  sim::CameraRenderSettings settings;
  settings.noise_sigma = static_cast<float>(noise().image_sigma);
  settings.max_range = kCameraRange;
  settings.threads = t;
  Frame f;
  f.index = i;
  f.stamp = stamp(i);
  settings.noise_seed = sim::subSeed(options_.seed, 4 * uint64_t(i) + 1);
  const bool after = impl_->after(f.stamp, options_.step);
  const Eigen::Isometry3d& T_cam2_lidar = after ? impl_->T_cam2_lidar_after : impl_->T_cam2_lidar;
  const Eigen::Isometry3d& T_cam3_lidar = after ? impl_->T_cam3_lidar_after : impl_->T_cam3_lidar;
  const sim::RealismDraw& r = impl_->realism;
  settings.lens_k1 = static_cast<float>(r.lens_k1);
  settings.vignetting = static_cast<float>(r.left_vignetting);
  f.left = sim::renderCamera(*world_, shadows, rig_.left, T_wl * T_cam2_lidar.inverse(),
                             {float(options_.left_gain), float(options_.left_offset)}, settings);
  settings.noise_seed = sim::subSeed(options_.seed, 4 * uint64_t(i) + 2);
  settings.vignetting = static_cast<float>(r.right_vignetting);
  settings.blur_sigma_px = static_cast<float>(r.right_blur_px);
  f.right = sim::renderCamera(*world_, shadows, rig_.right, T_wl * T_cam3_lidar.inverse(),
                              {float(options_.right_gain), float(options_.right_offset)}, settings);
  f.scan = renderScan(i, t);
  return f;
}

namespace {

/// Creates the output folders; an earlier tescalib_simulate output is replaced, any other
/// non-empty folder refused.
void prepareFolder(const std::string& dir) {
  const fs::path d(dir);
  std::error_code ec;
  if (fs::exists(d)) {
    if (!fs::is_directory(d)) throw DataError(dir + ": exists and is not a folder");
    const bool ours = fs::exists(d / "sim_info.txt");
    if (!ours && fs::directory_iterator(d) != fs::directory_iterator())
      throw DataError(dir +
                      ": folder is not empty and is not an earlier tescalib_simulate output; "
                      "refusing to overwrite it");
    for (const char* sub : {"image_2", "image_3", "velodyne"}) fs::remove_all(d / sub, ec);
  }
  for (const char* sub : {"image_2", "image_3", "velodyne"}) {
    fs::create_directories(d / sub, ec);
    if (ec) throw DataError((d / sub).string() + ": cannot create folder: " + ec.message());
  }
}

void writeTimesAndPoses(const Simulator& sim, const std::string& dir) {
  const fs::path d(dir);
  std::ofstream times(d / "times.txt");
  std::ofstream poses(d / "poses.txt");
  if (!times || !poses) throw DataError(dir + ": cannot write times.txt / poses.txt");
  char buf[32];
  for (int i = 0; i < sim.options().frames; i += sim.options().write_every) {
    std::snprintf(buf, sizeof(buf), "%.6e", sim.stamp(i));
    times << buf << "\n";
    writeRow(poses, sim.cam0Pose(i));
  }
}

/// sim_info.txt's lines on SimOptions::step (none without one).
std::string stepInfo(const Simulator& sim) {
  const ExtrinsicStep& step = sim.options().step;
  if (!step.active()) return "";
  std::ostringstream o;
  o << std::setprecision(10)
    << "# the true extrinsic steps at extrinsic_step_at_s (s of the drive) by exactly these\n"
    << "# rotation and translation; calib_after_step.txt holds the truth after it\n"
    << "extrinsic_step_at_s: " << step.at_s << "\n"
    << "extrinsic_step_rot_deg: " << step.rot_deg << "\n"
    << "extrinsic_step_trans_m: " << step.trans_m << "\n"
    << "extrinsic_step: " << (step.stereo ? "stereo" : "lidar") << "\n"
    << "T_cam_lidar_after_step: " << yamlList(sim.rigAfterStep().T_cam_lidar) << "\n"
    << "T_right_left_after_step: " << yamlList(sim.rigAfterStep().T_right_left) << "\n";
  return o.str();
}

/// sim_info.txt's lines on SimOptions::realism: the sizes and this drive's draw.
std::string realismInfo(const Simulator& sim) {
  const SimOptions& o = sim.options();
  if (o.realism.none()) return "";
  std::ostringstream s;
  s << "# real sensors' errors (tescalib_simulate --realism, --realism-set): the sizes, then\n"
    << "# this drive's values drawn from the seed; with the right camera moved, calib_true.txt\n"
    << "# and T_right_left_true hold the true rig (calib.txt the nominal one)\n"
    << "realism: " << o.realism_name << "\n"
    << o.realism.yaml() << sim.realism().yaml()
    << "T_right_left_true: " << yamlList(sim.trueRig().T_right_left) << "\n";
  return s.str();
}

/// sim_info.txt: the sequence's parameters and ground truth (YAML).
void writeSimInfo(const Simulator& sim, const sim::LidarModel& lidar, const std::string& dir) {
  std::ofstream info(fs::path(dir) / "sim_info.txt");
  if (!info) throw DataError(dir + ": cannot write sim_info.txt");
  const SimOptions& o = sim.options();
  const SimNoise n = sim.noise();
  const double a = o.right_gain / o.left_gain;
  const double b = o.right_offset - a * o.left_offset;
  const Eigen::Vector3f& sun = sim.world().sun;  // printed as float
  info << std::setprecision(10)
       << "# Parameters of a sequence generated by tescalib_simulate (YAML).\n"
       << "generator: tescalib_simulate\n"
       << "scenario: " << sim::scenarioName(o.scenario) << "\n"
       << "frames: " << o.frames << "\n"
       << "seed: " << o.seed << "\n"
       << "noise: " << noiseLevelName(o.noise) << "\n"
       << "frame_rate_hz: " << kFrameRate << "\n"
       << "written_every: " << o.write_every << "\n"
       << "image_width: " << o.width << "\n"
       << "image_height: " << o.height << "\n"
       << "lidar_beams: " << lidar.elevation_deg.size() << "\n"
       << "lidar_points_per_ring: " << lidar.points_per_ring << "\n"
       << "lidar_max_range_m: " << lidar.max_range << "\n"
       << "# rig: default (KITTI-like), random (drawn from the seed) or calib FILE\n"
       << "rig: " << o.rig_source << "\n"
       << "# the vehicle frame (x forward, y left, z up) is lidar_height_m above the ground; the\n"
       << "# LiDAR sits at T_vehicle_lidar in it (3x4, row major)\n"
       << "lidar_height_m: " << sim::kVehicleFrameHeight << "\n"
       << "T_vehicle_lidar: " << yamlList(o.T_vehicle_lidar) << "\n"
       << "# 1: each scan swept over its revolution (clockwise, 10 Hz, forward at the frame's\n"
       << "# stamp) as a raw driver delivers it; 0: every beam from the pose at the stamp\n"
       << "lidar_sweep: " << (o.lidar_sweep ? 1 : 0) << "\n"
       << "lidar_range_sigma_m: " << n.lidar_range_sigma_m << "\n"
       << "lidar_direction_sigma_deg: " << n.lidar_direction_sigma_deg << "\n"
       << "lidar_intensity_sigma: " << n.lidar_intensity_sigma << "\n"
       << "image_noise_sigma: " << n.image_sigma << "\n"
       << "# pixel = gain * scene_value + offset + noise; scene_value is shared by both cameras\n"
       << "left_gain: " << o.left_gain << "\n"
       << "left_offset: " << o.left_offset << "\n"
       << "right_gain: " << o.right_gain << "\n"
       << "right_offset: " << o.right_offset << "\n"
       << "# right = brightness_a * left + brightness_b (before noise and rounding)\n"
       << "brightness_a: " << a << "\n"
       << "brightness_b: " << b << "\n"
       << "# ground truth as KittiSequence reads it from calib.txt (3x4, row major)\n"
       << "T_cam_lidar: " << yamlList(sim.rig().T_cam_lidar) << "\n"
       << "T_right_left: " << yamlList(sim.rig().T_right_left) << "\n"
       << stepInfo(sim) << realismInfo(sim) << "sun_direction_world: [" << sun.x() << ", "
       << sun.y() << ", " << sun.z() << "]\n"
       << "poses: cam0 pose of each frame in the cam0 frame of frame 0 (KITTI convention)\n"
       << "lidar_motion: "
       << (o.lidar_sweep
               ? "swept (each scan over its 0.1 s revolution, clockwise, facing forward at the "
                 "camera trigger: a raw, motion-skewed scan)\n"
               : "none (each scan is taken at its frame's pose)\n");
}

/// Renders the frames written (SimOptions::write_every), in parallel, one thread each, into
/// image_2, image_3 and velodyne; the first error is thrown once all have ended.
void writeFrames(const Simulator& sim, const std::string& dir) {
  const fs::path d(dir);
  std::mutex error_mutex;
  std::string error;
  const std::vector<int> png_params = {cv::IMWRITE_PNG_COMPRESSION, 1};
  const int every = sim.options().write_every;
  parallelFor(sim.options().writtenFrames(), resolveThreads(sim.options().threads), [&](int k) {
    try {
      const Frame f = sim.renderFrame(k * every, 1);
      const std::string name = frameName(k);
      const std::string left = (d / "image_2" / (name + ".png")).string();
      const std::string right = (d / "image_3" / (name + ".png")).string();
      if (!cv::imwrite(left, f.left, png_params)) throw DataError(left + ": cannot write image");
      if (!cv::imwrite(right, f.right, png_params)) throw DataError(right + ": cannot write image");
      writeVelodyneBin((d / "velodyne" / (name + ".bin")).string(), f.scan);
    } catch (const std::exception& e) {
      const std::lock_guard<std::mutex> lock(error_mutex);
      if (error.empty()) error = e.what();
    }
  });
  if (!error.empty()) throw DataError(error);
}

}  // namespace

void Simulator::writeSequence(const std::string& dir) const {
  prepareFolder(dir);
  writeKittiOdometryCalib((fs::path(dir) / "calib.txt").string(), options_.calib);
  const fs::path after = fs::path(dir) / "calib_after_step.txt";
  std::error_code ec;
  if (options_.step.active())
    writeKittiOdometryCalib(after.string(), impl_->calib_after);
  else
    fs::remove(after, ec);  // an earlier output's
  const fs::path true_calib = fs::path(dir) / "calib_true.txt";
  if (impl_->realism.movesRightCamera())
    writeKittiOdometryCalib(true_calib.string(), impl_->true_calib);
  else
    fs::remove(true_calib, ec);
  writeTimesAndPoses(*this, dir);
  writeSimInfo(*this, impl_->lidar, dir);
  writeFrames(*this, dir);
}

void simulateSequence(const SimOptions& options, const std::string& out_dir) {
  Simulator(options).writeSequence(out_dir);
}

}  // namespace tescalib
