// Motion compensation of spinning-LiDAR scans ("de-skewing"). A scan is swept over one rotation
// (0.1 s at 10 Hz) while the vehicle moves: at 12.6 m/s the points at the edges of KITTI's camera
// view (+-40 deg of azimuth, +-11 ms from the camera trigger) are 14 cm from where they were when
// the image was taken. Each point is brought to the trigger instant with the sensor's velocity,
// estimated by registering the scan to a neighbouring one (constant velocity over the pair).
#pragma once

#include <string>

#include <Eigen/Core>

#include "tescalib/core/common/types.h"

namespace tescalib {

/// The sweep of the sensor: when each point was measured relative to the reference instant.
struct ScanSweep {
  double rate_hz = 10.0;  ///< rotations per second (KITTI's HDL-64E: 10 Hz)
  /// Sense of rotation seen from above (sensor z up): true for Velodyne sensors (azimuth
  /// atan2(y, x) decreasing with time).
  bool clockwise = true;
  /// Azimuth (rad, sensor frame) at the reference instant: KITTI triggers the cameras when the
  /// LiDAR faces forward (0). The sweep's seam is opposite to it.
  double reference_azimuth_rad = 0.0;
  /// Points without a time of their own (a cloud without a per-point time field) are timed by
  /// their azimuth with the model above: right only for a LiDAR phase-locked to the cameras (it
  /// faces reference_azimuth_rad at every image stamp, as KITTI's). false: such clouds are not
  /// de-skewed (hasPointTimes decides), since a wrong phase moves the estimate by decimetres.
  bool by_azimuth = true;
};

/// Whether any point of the scan has its own time (LidarPoint::time finite).
bool hasPointTimes(const LidarScan& scan);

/// Constant sensor velocity over a scan, in the sensor frame of the reference instant.
struct ScanMotion {
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();          ///< m/s
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  ///< rad/s (rotation vector rate)
  bool valid = false;
  double rms_m = 0;  ///< RMS point-to-point distance of the registration's inliers
  int inliers = 0;
  /// How well the scenes' planes pin the translation down in its weakest direction: the smallest
  /// over the largest eigenvalue of sum(n n^T) over the registered points' local plane normals.
  /// Generated urban pairs give 0.10-0.15 and the real KITTI pairs of
  /// ../shared/data 0.04-0.32; on the generated highway (road, guard rails) it is 0.003-0.013 and
  /// the registration slid 0.3-1.3 m along the road, a velocity 3-13 m/s wrong. Below
  /// kMinTranslationConstraint the motion is not valid.
  double translation_constraint = 0;
  std::string message;  ///< why it is not valid
};

constexpr double kMinTranslationConstraint = 0.02;

/// Time (s) of a point at azimuth `azimuth_rad` relative to the sweep's reference instant, in
/// [-0.5, 0.5) / rate.
double sweepTime(double azimuth_rad, const ScanSweep& sweep = {});

constexpr double kMaxScanMotionDt = 1.0;  ///< s; scans farther apart are refused

/// The sensor's motion between scan `a` (time 0) and scan `b` (time `dt` > 0) from a GICP
/// registration of `b` to `a` (points beyond 3 m, 0.3 m voxels; started at the forward offset that
/// overlaps the scans best, up to 70 m/s), as a constant velocity. `valid` is false with a message
/// when the scans are too small, dt is not positive or beyond kMaxScanMotionDt, the registration
/// does not fit, or the scene's planes leave a direction free (ScanMotion::translation_constraint:
/// a road between guard rails or a tunnel).
ScanMotion estimateScanMotion(const LidarScan& a, const LidarScan& b, double dt);

/// Moves every point of `scan` to where it was at the sweep's reference instant, for a sensor
/// moving with `motion` (no-op when it is not valid). A point's time is its own `time` plus
/// `time_offset` (the scan's stamp minus the reference instant, e.g. the image's) when the driver
/// gave one, else sweepTime of its azimuth.
void deskewScan(LidarScan* scan, const ScanMotion& motion, const ScanSweep& sweep = {},
                double time_offset = 0.0);

}  // namespace tescalib
