// tescalib_simulate's library: generates a driving sequence with exact ground truth (a LiDAR and
// a rectified stereo pair in a procedurally generated street) and writes it in the KITTI odometry
// layout that KittiSequence, tescalib_eval and kitti_to_bag read:
//   DIR/calib.txt     P0..P3 and Tr: the ground truth (T_cam_lidar, T_right_left; doc/offline.md)
//   DIR/times.txt     10 Hz stamps
//   DIR/image_2/, DIR/image_3/   NNNNNN.png, 8-bit RGB, left and right
//   DIR/velodyne/     NNNNNN.bin, float32 x y z intensity, KITTI ring order
//   DIR/poses.txt     cam0 pose of each frame in the first cam0 frame (KITTI convention, 3x4)
//   DIR/sim_info.txt  the generator's parameters (scenario, seed, noise, exposures, ...)
//   DIR/calib_after_step.txt  with SimOptions::step: the ground truth after the step
//   DIR/calib_true.txt  with SimOptions::realism moving the right camera: the true rig (calib.txt
//                       holds the nominal rectified pair the data are rectified with)
// The same options give the same bytes (no time-based randomness, no thread-order dependence).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include <Eigen/Geometry>

#include "tescalib/core/common/types.h"
#include "tescalib/core/io/kitti_reader.h"
#include "tescalib/core/sim/random_rig.h"
#include "tescalib/core/sim/scene_builder.h"
#include "tescalib/core/sim/sensor_realism.h"

namespace tescalib {

using sim::Scenario;

/// Sensor noise presets of the generator.
enum class NoiseLevel { kNone, kDefault, kHigh };

/// "none" | "default" | "high".
std::string noiseLevelName(NoiseLevel n);
/// Parses a noise level name; returns false on an unknown name.
bool parseNoiseLevel(const std::string& name, NoiseLevel* n);

/// Noise parameters behind a NoiseLevel.
struct SimNoise {
  double lidar_range_sigma_m = 0.02;        ///< sigma_d, along the beam
  double lidar_direction_sigma_deg = 0.03;  ///< sigma_l, per tangent axis of the beam
  double lidar_intensity_sigma = 0.01;      ///< reflectance (0..1)
  double image_sigma = 2.0;                 ///< Gaussian image noise, grey levels per channel

  static SimNoise forLevel(NoiseLevel level);
};

/// The KITTI-like default rig: fx = fy = 718.856, cx 607.1928, cy 185.2157 (1241x376),
/// cam2 6 cm left of cam0, 0.54 m baseline, Tr of the 2011_09_30 recordings.
KittiOdometryCalib defaultSimCalib();

/// A change of one true extrinsic during the drive (a bumped LiDAR mount or camera): from
/// `at_s` on, T_cam_lidar (or T_right_left with `stereo`) is the one before moved by exactly
/// `rot_deg` about and `trans_m` along random directions drawn from the sequence's seed. The
/// cameras stay where they are on the vehicle; with a LiDAR step the LiDAR moves, with a stereo
/// step the right camera.
struct ExtrinsicStep {
  double at_s = -1;  ///< s of the drive; < 0: no step
  double rot_deg = 0;
  double trans_m = 0;
  bool stereo = false;  ///< false: T_cam_lidar steps; true: T_right_left
  bool active() const { return at_s >= 0; }
};

/// Everything that defines a generated sequence.
struct SimOptions {
  Scenario scenario = Scenario::kUrban;          ///< what the world looks like
  int frames = 100;                              ///< number of frames (10 Hz)
  uint64_t seed = 1;                             ///< world, trajectory and noise seed
  NoiseLevel noise = NoiseLevel::kDefault;       ///< sensor noise preset
  KittiOdometryCalib calib = defaultSimCalib();  ///< rig and ground truth (P2, P3, Tr used)
  int width = 1241;                              ///< image width (px)
  int height = 376;                              ///< image height (px)
  double left_gain = 1.0;                        ///< left camera: pixel = gain * scene + offset
  double left_offset = 0.0;                      ///< grey levels
  double right_gain = 0.9;                       ///< right camera gain
  double right_offset = 8.0;                     ///< right camera offset (grey levels)
  int threads = 0;                               ///< worker threads, 0 = all cores
  /// Write only frames 0, k, 2k, ... of the drive (numbered 0, 1, 2, ... with their own stamps
  /// and poses): the same drive at a keyframe rate (5: 2 Hz), 1/k of the rendering.
  int write_every = 1;
  /// How many frames the sequence's folder holds: frames 0, write_every, ... below `frames`.
  int writtenFrames() const { return (frames + write_every - 1) / write_every; }
  /// Sweep each scan over its 0.1 s revolution as a real spinning LiDAR does (clockwise, the
  /// cameras triggered when it faces forward): a raw, motion-skewed scan. Off: every beam fires
  /// from the pose of the camera trigger (a perfectly motion-compensated scan).
  bool lidar_sweep = false;
  /// Where the LiDAR sits on the vehicle: the trajectory moves the vehicle frame (x forward, y
  /// left, z up, 1.73 m above the ground), the cameras follow the LiDAR through `calib`'s Tr.
  /// Identity: the LiDAR is the vehicle frame, as KITTI's is.
  Eigen::Isometry3d T_vehicle_lidar = Eigen::Isometry3d::Identity();
  /// How the rig was chosen, for sim_info.txt ("default", "random", "calib FILE").
  std::string rig_source = "default";
  /// A change of the true extrinsic during the drive (written as calib_after_step.txt).
  ExtrinsicStep step;
  /// Real sensors' errors (sizes; each drive draws its values from `seed`) and the name of the
  /// preset they started from, for sim_info.txt.
  sim::RealismSizes realism;
  std::string realism_name = "none";
};

/// Options whose rig (calib, image size, LiDAR mounting) is drawn from `seed`
/// (sim::randomSimRig): the other options are left as they are.
void useRandomRig(uint64_t seed, SimOptions* options);

/// A generated sequence: the world is built once; frames are rendered on demand.
class Simulator {
 public:
  /// Builds the world and the trajectory. Throws DataError on invalid options (the message says
  /// which value is wrong).
  explicit Simulator(const SimOptions& options);
  ~Simulator();
  Simulator(const Simulator&) = delete;
  Simulator& operator=(const Simulator&) = delete;

  const SimOptions& options() const { return options_; }
  /// The rig as KittiSequence will read it back (image size filled in): with a step, the truth
  /// before it.
  const StereoRig& rig() const { return rig_; }
  /// The truth after SimOptions::step (rig() without one), and its calib.txt.
  const StereoRig& rigAfterStep() const;
  const KittiOdometryCalib& calibAfterStep() const;
  /// Time stamp of frame i (s): 0.1 * i.
  double stamp(int i) const { return 0.1 * i; }
  /// Pose of the vehicle frame in the world at time t (s).
  Eigen::Isometry3d worldFromVehicleAt(double t) const;
  /// Pose of the LiDAR in the world at frame i.
  Eigen::Isometry3d worldFromLidar(int i) const;
  /// Pose of the LiDAR in the world at time t (s; the trajectory is continuous: a swept scan's
  /// beams fire from the poses around their frame's stamp).
  Eigen::Isometry3d worldFromLidarAt(double t) const;
  /// Pose of cam0 at frame i in the cam0 frame of frame 0 (what poses.txt holds).
  Eigen::Isometry3d cam0Pose(int i) const;
  /// The noise parameters in use.
  SimNoise noise() const { return SimNoise::forLevel(options_.noise); }
  /// This drive's real sensors' errors (all off without SimOptions::realism).
  const sim::RealismDraw& realism() const;
  /// The true rig: rig() with the right camera where SimOptions::realism put it.
  const StereoRig& trueRig() const;
  /// calib.txt of the true rig (written as calib_true.txt when it differs from calib.txt).
  const KittiOdometryCalib& trueCalib() const;

  /// Renders frame i in memory: scan (with rings) and both images (BGR). `threads` 0 = the
  /// options' thread count.
  Frame renderFrame(int i, int threads = 0) const;
  /// Only the LiDAR scan of frame i.
  LidarScan renderScan(int i, int threads = 0) const;
  /// The generated world (for inspection and tests).
  const sim::SceneWorld& world() const { return *world_; }

  /// Writes the whole sequence to `dir` (created if needed). An existing folder must be empty
  /// or hold an earlier tescalib_simulate output (its files are replaced). Throws DataError.
  void writeSequence(const std::string& dir) const;

 private:
  struct Impl;
  SimOptions options_;
  StereoRig rig_;
  std::unique_ptr<sim::SceneWorld> world_;
  std::unique_ptr<Impl> impl_;
};

/// Convenience: Simulator(options).writeSequence(out_dir).
void simulateSequence(const SimOptions& options, const std::string& out_dir);

}  // namespace tescalib
