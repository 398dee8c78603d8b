#include <cmath>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/common/pose_format.h"

using namespace tescalib;

TEST(PoseFormat, AYawAloneIsItsAngleAboutZ) {
  const Eigen::Matrix3d R = Eigen::AngleAxisd(30 / kDegPerRad, Eigen::Vector3d::UnitZ()).matrix();
  const Eigen::Vector3d rpy = rollPitchYaw(R) * kDegPerRad;
  EXPECT_NEAR(rpy.x(), 0, 1e-12);
  EXPECT_NEAR(rpy.y(), 0, 1e-12);
  EXPECT_NEAR(rpy.z(), 30, 1e-12);
  // Roll and pitch alone, each about its own axis.
  EXPECT_NEAR(rollPitchYaw(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX()).matrix()).x(), 0.2,
              1e-12);
  EXPECT_NEAR(rollPitchYaw(Eigen::AngleAxisd(-0.3, Eigen::Vector3d::UnitY()).matrix()).y(), -0.3,
              1e-12);
}

TEST(PoseFormat, ACameraOpticalFrameUnderALidarHasTfsKnownAngles) {
  // A camera's optical frame (x right, y down, z forward) under a LiDAR frame (x forward, y left,
  // z up): the optical axis is the LiDAR's x. tf writes it as roll -90, pitch 0, yaw -90 deg, the
  // quaternion (x y z w) [-0.5 0.5 -0.5 0.5].
  Eigen::Matrix3d R_lidar_cam;
  R_lidar_cam << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  const Eigen::Vector3d rpy = rollPitchYaw(R_lidar_cam) * kDegPerRad;
  EXPECT_NEAR(rpy.x(), -90, 1e-9);
  EXPECT_NEAR(rpy.y(), 0, 1e-9);
  EXPECT_NEAR(rpy.z(), -90, 1e-9);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R_lidar_cam;
  T.translation() = Eigen::Vector3d(0.27, -0.08, -0.12);
  EXPECT_EQ(describeTransform("velo_link", "tescalib_left", T),
            "velo_link -> tescalib_left:\n"
            "  translation [+0.2700 -0.0800 -0.1200] m\n"
            "  quaternion (x y z w) [-0.500000 +0.500000 -0.500000 +0.500000]\n"
            "  roll/pitch/yaw [-90.0000 +0.0000 -90.0000] deg (R = Rz(yaw) Ry(pitch) Rx(roll), "
            "as tf)");
  // The quaternion is shown with w >= 0, whichever sign the matrix gives.
  T.linear() = Eigen::AngleAxisd(350 / kDegPerRad, Eigen::Vector3d::UnitZ()).matrix();
  T.translation().setZero();
  EXPECT_NE(describeTransform("a", "b", T).find("[+0.000000 +0.000000 -0.087156 +0.996195]"),
            std::string::npos)
      << describeTransform("a", "b", T);
}

TEST(PoseFormat, RollPitchYawRoundTrips) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI),
      half(-M_PI / 2 + 1e-3, M_PI / 2 - 1e-3);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d rpy(angle(rng), half(rng), angle(rng));
    const Eigen::Matrix3d R = fromRollPitchYaw(rpy);
    EXPECT_LT((rollPitchYaw(R) - rpy).norm(), 1e-9) << rpy.transpose();
    EXPECT_LT((fromRollPitchYaw(rollPitchYaw(R)) - R).norm(), 1e-9);
  }
  // At pitch +-90 deg only roll - yaw (or roll + yaw) is defined: the angles found give R back.
  for (double pitch : {M_PI / 2, -M_PI / 2}) {
    const Eigen::Matrix3d R = fromRollPitchYaw(Eigen::Vector3d(0.4, pitch, -0.3));
    const Eigen::Vector3d rpy = rollPitchYaw(R);
    EXPECT_NEAR(rpy.y(), pitch, 1e-9);
    EXPECT_EQ(rpy.z(), 0.0);
    EXPECT_LT((fromRollPitchYaw(rpy) - R).norm(), 1e-9);
  }
}
