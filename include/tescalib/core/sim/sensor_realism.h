// Real sensors' errors for the generated drives: what a real rig's calibration leaves behind
// (the stereo pair's residual rotation and f x B error, residual lens distortion), what a real
// camera pair differs in (sharpness, vignetting), what a real spinning LiDAR does (per-laser range
// offsets and elevation errors, a range scale, mixed pixels at depth edges), a LiDAR-camera time
// offset, and road surfaces as poor in texture as real asphalt.
//
// RealismSizes says how large each source is (a preset, then KEY=VALUE changes); drawRealism
// draws one drive's values from the drive's seed. calib.txt keeps the nominal rectified pair (what
// a user's stereo calibration says); the drive's true right camera is the nominal one moved by
// the drawn rotation and baseline scale (written to calib_true.txt and sim_info.txt).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Geometry>

namespace tescalib {
namespace sim {

/// The size of every error source (0 switches it off). Signed errors are drawn per drive from
/// N(0, size^2) (per axis or per laser); magnitudes from size * U(0.5, 1.5).
struct RealismSizes {
  // The stereo pair.
  double right_rotation_deg = 0;  ///< residual rotation of the right camera, rms per axis
  double baseline_scale = 0;      ///< relative error of f x B (a disparity scale), rms
  double lens_k1 = 0;             ///< residual radial distortion of both images, rms of k1
  double right_blur_px = 0;       ///< the right camera's extra blur (Gaussian sigma, px)
  double vignetting = 0;          ///< brightness lost at the image corners (fraction), per camera
  // The LiDAR.
  double laser_range_offset_m = 0;  ///< per-laser range offsets, rms (fixed per laser)
  double laser_elevation_deg = 0;   ///< per-laser elevation errors, rms (fixed per laser)
  double range_scale = 0;           ///< relative range scale error, rms
  double mixed_pixel_fraction = 0;  ///< share of beams at depth edges that return a mixed range
  double lidar_time_offset_s = 0;   ///< LiDAR clock minus camera clock, rms (s)
  // The road.
  double asphalt_texture = 1;  ///< contrast of the asphalt's grain (1: the clean drives' texture)

  /// "none": every source off (the clean drives); "kitti": sizes whose signatures
  /// (tescalib_check_data) fall within those of the real KITTI recordings.
  static bool preset(const std::string& name, RealismSizes* sizes);
  /// Applies "KEY=VALUE[,KEY=VALUE...]" (keys as the fields' names). Returns an empty string on
  /// success, else the message naming the wrong key or value.
  std::string set(const std::string& assignments);
  /// True when every source is off.
  bool none() const;
  /// "key: value" lines (YAML) of every size.
  std::string yaml() const;
};

/// One drive's errors, drawn from its seed.
struct RealismDraw {
  Eigen::Matrix3d right_rotation = Eigen::Matrix3d::Identity();  ///< true R_right / nominal R_right
  double baseline_scale = 1;  ///< true baseline / nominal baseline
  double lens_k1 = 0;         ///< both images: x_image = x (1 + k1 r^2)
  double right_blur_px = 0;
  double left_vignetting = 0, right_vignetting = 0;
  std::vector<double> laser_range_offset_m;  ///< per ring (ring 0 lowest)
  std::vector<double> laser_elevation_rad;   ///< per ring: true minus nominal elevation
  double range_scale = 1;                    ///< reported range / true range (before offsets)
  double mixed_pixel_fraction = 0;
  double lidar_time_offset_s = 0;
  double asphalt_texture = 1;

  /// True when the true right camera differs from the nominal one.
  bool movesRightCamera() const;
  /// The true T_right_left from the nominal one: rotation and baseline scale applied.
  Eigen::Isometry3d trueRightLeft(const Eigen::Isometry3d& nominal) const;
  /// "key: value" lines (YAML) of the drawn values.
  std::string yaml() const;
};

/// The drive's errors: `sizes` drawn from `seed` for a LiDAR of `rings` lasers. Sizes of 0 give
/// exactly the clean values.
RealismDraw drawRealism(const RealismSizes& sizes, uint64_t seed, int rings);

}  // namespace sim
}  // namespace tescalib
