// The calibration node's starting rig (initialRig): every source of the initial extrinsics and
// every way it can be missing, without a ROS master.
#include <gtest/gtest.h>

#include <geometry_msgs/TransformStamped.h>
#include <ros/time.h>
#include <tf2_ros/buffer.h>

#include "tescalib/core/common/geometry.h"
#include "tescalib/ros/conversions.h"
#include "tescalib/ros/initial_rig.h"

namespace tescalib {
namespace {

/// KITTI-like rectified pair, ROS's convention (right P[3] = -fx * 0.54).
struct Inputs {
  sensor_msgs::PointCloud2 cloud;
  sensor_msgs::CameraInfo left, right;
  tf2_ros::Buffer tf;
  Eigen::Isometry3d T_cam_lidar = Eigen::Isometry3d::Identity();

  Inputs() {
    ros::Time::init();
    tf.setUsingDedicatedThread(true);  // as the node's TransformListener does
    CameraIntrinsics c;
    c.fx = c.fy = 718.856, c.cx = 607.19, c.cy = 185.22, c.width = 1241, c.height = 376;
    std_msgs::Header h;
    h.frame_id = "camera_left";
    left = ros_conv::toCameraInfo(c, 0.0, h);
    h.frame_id = "camera_right";
    right = ros_conv::toCameraInfo(c, -c.fx * 0.54, h);
    cloud.header.frame_id = "velo_link";
    T_cam_lidar.linear() =
        Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitY()).toRotationMatrix() *
        Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
    T_cam_lidar.translation() = Eigen::Vector3d(0.01, -0.08, -0.27);
  }
  void publishTf(const std::string& camera_frame) {
    geometry_msgs::TransformStamped t;
    t.header.frame_id = camera_frame;
    t.child_frame_id = "velo_link";
    t.transform = ros_conv::toTransformMsg(T_cam_lidar);
    tf.setTransform(t, "test", /*is_static=*/true);
  }
};

/// A named default parameter set (a temporary inside EXPECT_* makes GCC 12 warn).
const NodeParams defaults;

double rotationDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() * kDegPerRad;
}

TEST(InitialRig, FromTfWithTheLeftCameraInfosFrame) {
  Inputs in;
  in.publishTf("camera_left");
  InitialRig r;
  std::string error;
  ASSERT_TRUE(initialRig(defaults, in.cloud, in.left, in.right, in.tf, 0.0, &r, &error)) << error;
  EXPECT_EQ(r.lidar_frame, "velo_link");
  EXPECT_LT(rotationDeg(r.rig.T_cam_lidar, in.T_cam_lidar), 1e-9);
  EXPECT_LT((r.rig.T_cam_lidar.translation() - in.T_cam_lidar.translation()).norm(), 1e-9);
  EXPECT_NEAR(r.rig.T_right_left.translation().x(), -0.54, 1e-9);
  EXPECT_NEAR(r.rig.left.fx, 718.856, 1e-9);
  EXPECT_EQ(r.rig.left.width, 1241);
  EXPECT_TRUE(r.warnings.empty());
}

TEST(InitialRig, TheCameraFrameParameterAndTheLidarFrameParameterWin) {
  Inputs in;
  in.cloud.header.frame_id = "velodyne";  // the cloud's own frame is not the one on tf
  in.publishTf("cam_rect");
  NodeParams p;
  p.initial_tf_camera_frame = "cam_rect";
  p.lidar_frame = "velo_link";
  InitialRig r;
  std::string error;
  ASSERT_TRUE(initialRig(p, in.cloud, in.left, in.right, in.tf, 0.0, &r, &error)) << error;
  EXPECT_EQ(r.lidar_frame, "velo_link");
  EXPECT_LT(rotationDeg(r.rig.T_cam_lidar, in.T_cam_lidar), 1e-9);
  // The clouds are not transformed into frames/lidar: the node says so.
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("not the clouds' frame 'velodyne'"), std::string::npos)
      << r.warnings[0];
}

TEST(InitialRig, OutputFramesThatAlreadyHaveAParentAreRefused) {
  // frames/left set to the camera's real frame would give it two parents, silently.
  Inputs in;
  in.publishTf("camera_left");        // camera_left -> velo_link, as the tests' tf has it
  geometry_msgs::TransformStamped t;  // and velo_link -> camera_right, as kitti2bag bags have it
  t.header.frame_id = "velo_link";
  t.child_frame_id = "camera_right";
  t.transform.rotation.w = 1.0;
  in.tf.setTransform(t, "test", /*is_static=*/true);
  NodeParams p;
  p.left_frame = "camera_right";
  InitialRig r;
  std::string error;
  EXPECT_FALSE(initialRig(p, in.cloud, in.left, in.right, in.tf, 0.0, &r, &error));
  EXPECT_NE(error.find("frames/left 'camera_right' already has a parent on tf ('velo_link'"),
            std::string::npos)
      << error;
  p.left_frame = "camera_left";  // the LiDAR's parent: the node's edge would close a loop
  EXPECT_FALSE(initialRig(p, in.cloud, in.left, in.right, in.tf, 0.0, &r, &error));
  EXPECT_NE(error.find("frames/left 'camera_left' is above the LiDAR's frame"), std::string::npos)
      << error;
  p = NodeParams{};
  p.right_frame = "velo_link";
  EXPECT_FALSE(initialRig(p, in.cloud, in.left, in.right, in.tf, 0.0, &r, &error));
  EXPECT_NE(error.find("frames/right 'velo_link' is the LiDAR's frame"), std::string::npos)
      << error;
  // A frame that is only a parent elsewhere (nothing above it) is not refused.
  t.header.frame_id = "tescalib_left";
  t.child_frame_id = "some_tool";
  in.tf.setTransform(t, "test", /*is_static=*/true);
  EXPECT_TRUE(initialRig(defaults, in.cloud, in.left, in.right, in.tf, 0.0, &r, &error)) << error;
}

TEST(InitialRig, WithoutATransformItSaysWhatToPublishOrSet) {
  Inputs in;  // nothing on tf
  InitialRig r;
  std::string error;
  EXPECT_FALSE(initialRig(defaults, in.cloud, in.left, in.right, in.tf, 0.0, &r, &error));
  EXPECT_NE(error.find("tf velo_link -> camera_left"), std::string::npos) << error;
  EXPECT_NE(error.find("the left camera_info's frame_id"), std::string::npos) << error;
  EXPECT_NE(error.find("camera_frame:="), std::string::npos) << error;
  EXPECT_NE(error.find("initial/T_cam_lidar"), std::string::npos) << error;

  in.left.header.frame_id.clear();  // and no frame to look up at all
  EXPECT_FALSE(initialRig(defaults, in.cloud, in.left, in.right, in.tf, 0.0, &r, &error));
  EXPECT_NE(error.find("no frame_id"), std::string::npos) << error;
}

TEST(InitialRig, ParametersGiveBothExtrinsicsWithoutTf) {
  Inputs in;  // nothing on tf: initial/T_cam_lidar needs none
  NodeParams p;
  const Eigen::Quaterniond q(in.T_cam_lidar.linear());
  const Eigen::Vector3d t = in.T_cam_lidar.translation();
  p.initial_T_cam_lidar = {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()};
  p.initial_T_right_left = {-0.5, 0.01, 0.0, 0.0, 0.0, 0.0, 2.0};  // quaternion normalised
  InitialRig r;
  std::string error;
  ASSERT_TRUE(initialRig(p, in.cloud, in.left, in.right, in.tf, 0.0, &r, &error)) << error;
  EXPECT_LT(rotationDeg(r.rig.T_cam_lidar, in.T_cam_lidar), 1e-6);
  EXPECT_LT((r.rig.T_cam_lidar.translation() - t).norm(), 1e-12);
  EXPECT_LT((r.rig.T_right_left.translation() - Eigen::Vector3d(-0.5, 0.01, 0)).norm(), 1e-12);
  EXPECT_TRUE(r.rig.T_right_left.linear().isIdentity(1e-12));
  // Clouds without a frame_id: without the tf lookup nothing else would refuse them, and the
  // estimate's tf edge would have an empty parent, which every tf listener drops.
  in.cloud.header.frame_id = "";
  EXPECT_FALSE(initialRig(p, in.cloud, in.left, in.right, in.tf, 0.0, &r, &error));
  EXPECT_NE(error.find("no frame_id and frames/lidar is not set"), std::string::npos) << error;
  p.lidar_frame = "velodyne";  // ... unless frames/lidar names it
  EXPECT_TRUE(initialRig(p, in.cloud, in.left, in.right, in.tf, 0.0, &r, &error)) << error;
  EXPECT_EQ(r.lidar_frame, "velodyne");
}

TEST(InitialRig, ThePerturbationAndARectifyingRAreSaid) {
  Inputs in;
  in.publishTf("camera_left");
  in.left.R = {1, 0, 0, 0, 0.99984769515, -0.01745240644, 0, 0.01745240644, 0.99984769515};
  NodeParams p;
  p.initial_perturb_rot_deg = 2.0;
  p.initial_perturb_trans_m = 0.2;
  InitialRig r;
  std::string error;
  ASSERT_TRUE(initialRig(p, in.cloud, in.left, in.right, in.tf, 0.0, &r, &error)) << error;
  EXPECT_NEAR(rotationDeg(r.rig.T_cam_lidar, in.T_cam_lidar), 2.0, 1e-6);
  const Vector6d e = poseError(r.rig.T_cam_lidar, in.T_cam_lidar);
  EXPECT_NEAR(e.tail<3>().norm(), 0.2, 0.02);  // the rotation moves the translation a little
  ASSERT_EQ(r.warnings.size(), 2u);
  EXPECT_NE(r.warnings[0].find("R is a rotation of 1.00 deg"), std::string::npos) << r.warnings[0];
  EXPECT_NE(r.warnings[1].find("deliberately perturbed by 2.00 deg / 0.200 m"), std::string::npos)
      << r.warnings[1];
}

TEST(InitialRig, LeadingSlashesOfTf1AreDropped) {
  Inputs in;
  in.publishTf("camera_left");
  in.cloud.header.frame_id = "/velo_link";
  in.left.header.frame_id = "/camera_left";
  InitialRig r;
  std::string error;
  ASSERT_TRUE(initialRig(defaults, in.cloud, in.left, in.right, in.tf, 0.0, &r, &error)) << error;
  EXPECT_EQ(r.lidar_frame, "velo_link");
  EXPECT_LT(rotationDeg(r.rig.T_cam_lidar, in.T_cam_lidar), 1e-9);
}

TEST(InitialRig, LensDistortionIsSaid) {
  Inputs in;
  in.publishTf("camera_left");
  in.left.D = {-0.2, 0.1, 0, 0, 0};
  in.right.D = {0, 0, 0, 0, 0};
  InitialRig r;
  std::string error;
  ASSERT_TRUE(initialRig(defaults, in.cloud, in.left, in.right, in.tf, 0.0, &r, &error)) << error;
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("D is not zero"), std::string::npos) << r.warnings[0];
  EXPECT_NE(r.warnings[0].find("image_rect"), std::string::npos) << r.warnings[0];
  in.left.D = {0, 0, 0, 0, 0};  // all zero: nothing to say
  ASSERT_TRUE(initialRig(defaults, in.cloud, in.left, in.right, in.tf, 0.0, &r, &error)) << error;
  EXPECT_TRUE(r.warnings.empty());
}

TEST(InitialRig, UnusableCameraInfosAreRefused) {
  Inputs in;
  in.publishTf("camera_left");
  in.right.P = {};  // all zero
  InitialRig r;
  std::string error;
  EXPECT_FALSE(initialRig(defaults, in.cloud, in.left, in.right, in.tf, 0.0, &r, &error));
  // Refused for the camera_info, not for something else on the way.
  EXPECT_NE(error.find("unusable camera_info: camera_info has no rectified projection matrix P"),
            std::string::npos)
      << error;
}

}  // namespace
}  // namespace tescalib
