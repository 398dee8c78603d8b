// KITTI's calibration files (ROS-free): the odometry layout's calib.txt (P0..P3, Tr), which
// tescalib_simulate and tescalib_calibrate also write, and a raw drive's calib_cam_to_cam.txt and
// calib_velo_to_cam.txt. Ground truth (see the data README):
//   T_cam_lidar = [I | K^-1 P2[:,3]] * Tr,   T_right_left = [I | K^-1 (P3[:,3] - P2[:,3])].
#pragma once

#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "tescalib/core/common/types.h"

namespace tescalib {

/// The parsed calibration of a KITTI odometry `calib.txt`.
struct KittiOdometryCalib {
  Eigen::Matrix<double, 3, 4> P[4];  ///< rectified projection matrices P0..P3
  Eigen::Matrix<double, 3, 4> Tr;    ///< velodyne -> rectified cam0
  /// Not part of KITTI's format: the rotation of the right camera relative to the left one,
  /// which a rectified P3 cannot hold. tescalib writes it as an extra line `R_right_left:` (9
  /// values, row major) when a co-calibrated pair is not exactly rectified, so that its
  /// `_calib.txt` reads back as the estimate; KITTI's files have none (identity).
  Eigen::Matrix3d R_right_left = Eigen::Matrix3d::Identity();
};

/// Parses a KITTI odometry calib.txt. Throws DataError naming the file and the bad key.
KittiOdometryCalib readKittiOdometryCalib(const std::string& path);

/// A KITTI odometry calib.txt's text (P0..P3 and Tr, 12 values each, row major).
std::string kittiOdometryCalibText(const KittiOdometryCalib& calib);

/// Writes a KITTI odometry calib.txt (kittiOdometryCalibText).
void writeKittiOdometryCalib(const std::string& path, const KittiOdometryCalib& calib);

/// Rig from odometry calibration: rectified intrinsics from P2/P3, ground truth as above.
/// Image sizes are left 0 here; the reader fills them from the images.
StereoRig rigFromOdometryCalib(const KittiOdometryCalib& calib);

/// readKittiOdometryCalib + rigFromOdometryCalib, checked as a sequence's calibration is
/// (positive focal lengths, a rotation in Tr, a rigid left->right transform with a baseline):
/// throws DataError naming what is wrong. For a calibration given on its own (an initial guess).
StereoRig readCheckedOdometryRig(const std::string& path);

/// A raw drive's calibration in the odometry form: P_rect_00..03 of calib_cam_to_cam.txt and
/// Tr = R_rect_00 [R | T] (velodyne -> rectified cam0) of calib_velo_to_cam.txt. `width`,
/// `height`: the rectified image size S_rect_02 (0 when the file has none). Throws DataError
/// naming the file and the missing or malformed key.
KittiOdometryCalib readKittiRawCalib(const std::string& cam_to_cam, const std::string& velo_to_cam,
                                     int* width, int* height);

/// Throws DataError naming `source` unless the rig is one the solvers can start from: positive
/// focal lengths, P2/P3 of the form K [I | t], a rotation in Tr and a rigid left -> right
/// transform with a baseline.
void checkKittiRig(const StereoRig& rig, const KittiOdometryCalib& calib,
                   const std::string& source);

}  // namespace tescalib
