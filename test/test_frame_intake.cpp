// FrameIntake, the one path from a synchronized message set to a keyframe candidate that the
// nodelet and tescalib_calibrate --bag share: skewed, unsynchronised and malformed sets are
// refused with their reason, without a master.
#include <memory>
#include <string>

#include <gtest/gtest.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <opencv2/core.hpp>

#include "tescalib/core/io/kitti_reader.h"
#include "tescalib/core/online/online_calibrator.h"
#include "tescalib/ros/conversions.h"
#include "tescalib/ros/frame_intake.h"
#include "test_util.h"

using namespace tescalib;

namespace {

constexpr double kMaxStereoSkew = 0.02;

/// A synchronized set at `stamp`: a 64-ring cloud, a 64x48 stereo pair and their camera_infos;
/// each message's stamp can be moved afterwards.
struct MessageSet {
  sensor_msgs::PointCloud2 cloud;
  sensor_msgs::Image left, right;
  sensor_msgs::CameraInfo left_info, right_info;

  explicit MessageSet(double stamp, int rings = 64) {
    std_msgs::Header h;
    h.stamp = ros::Time(stamp);
    h.frame_id = "velodyne";
    LidarScan scan = tescalib_test::syntheticScan(rings, 50);
    recoverRings(scan);
    cloud = ros_conv::toPointCloud2(scan, h);
    h.frame_id = "camera_left";
    const cv::Mat image(48, 64, CV_8UC3, cv::Scalar(40, 80, 120));
    left = ros_conv::toImageMsg(image, h, "bgr8");
    left_info = ros_conv::toCameraInfo(intrinsics(), 0.0, h);
    h.frame_id = "camera_right";
    right = ros_conv::toImageMsg(image, h, "bgr8");
    right_info = ros_conv::toCameraInfo(intrinsics(), -50.0 * 0.5, h);
  }

  static CameraIntrinsics intrinsics() {
    CameraIntrinsics c;
    c.fx = c.fy = 50.0;
    c.cx = 32.0;
    c.cy = 24.0;
    c.width = 64;
    c.height = 48;
    return c;
  }

  IntakeResult into(FrameIntake* intake) const {
    return intake->take(cloud, left, left_info, right, right_info);
  }
};

/// An intake started on `first`'s camera_infos, as both callers start it with the rig.
std::unique_ptr<FrameIntake> startedIntake(const OnlineSettings& settings,
                                           const MessageSet& first) {
  auto intake = std::make_unique<FrameIntake>(settings, kMaxStereoSkew);
  intake->start(first.left_info, first.right_info);
  return intake;
}

}  // namespace

TEST(FrameIntake, CandidatesAreSpacedByTheKeyframeIntervalAndTimeGoingBackIsPassedOn) {
  OnlineSettings settings;  // keyframe_min_dt 0.5 s, no de-skewing
  const MessageSet first(100.0);
  FrameIntake intake(settings, kMaxStereoSkew);
  intake.start(first.left_info, first.right_info);

  IntakeResult r = first.into(&intake);
  ASSERT_EQ(r.outcome, IntakeOutcome::kCandidate) << r.reason;
  EXPECT_FALSE(r.refused());
  EXPECT_DOUBLE_EQ(r.candidate.frame.stamp, 100.0);
  EXPECT_DOUBLE_EQ(r.candidate.lidar_stamp, 100.0);
  EXPECT_EQ(r.candidate.frame.scan.size(), 64u * 50u);
  EXPECT_EQ(r.candidate.frame.left.cols, 64);
  EXPECT_EQ(r.candidate.frame.right.rows, 48);
  EXPECT_FALSE(r.candidate.previous_scan);  // no de-skewing
  EXPECT_EQ(r.rings, 64);                   // counted on the first candidate only
  EXPECT_FALSE(r.camera_info_changed);

  // 0.1 s later: not a candidate, skipped without a word and without converting anything.
  r = MessageSet(100.1).into(&intake);
  EXPECT_EQ(r.outcome, IntakeOutcome::kNotCandidate);
  EXPECT_FALSE(r.refused());
  EXPECT_TRUE(r.reason.empty());
  EXPECT_FALSE(r.cloud_converted);

  r = MessageSet(100.5).into(&intake);
  ASSERT_EQ(r.outcome, IntakeOutcome::kCandidate) << r.reason;
  EXPECT_EQ(r.rings, -1);

  // A looping bag: time going backwards is a candidate (the calibrator resets its window).
  r = MessageSet(50.0).into(&intake);
  EXPECT_EQ(r.outcome, IntakeOutcome::kCandidate) << r.reason;

  // After a reset of the window, the selection restarts from the given stamp.
  intake.restartSelection(60.0);
  EXPECT_EQ(MessageSet(60.2).into(&intake).outcome, IntakeOutcome::kNotCandidate);
  intake.restartSelection();
  EXPECT_EQ(MessageSet(60.3).into(&intake).outcome, IntakeOutcome::kCandidate);
}

TEST(FrameIntake, ALeftRightSkewBeyondTheLimitIsRefused) {
  OnlineSettings settings;
  MessageSet skewed(200.0);
  const auto owner = startedIntake(settings, skewed);
  FrameIntake& intake = *owner;
  // A dropped right frame: the sync paired the left image with the right one before it.
  skewed.right.header.stamp = ros::Time(200.0 - 0.1);
  IntakeResult r = skewed.into(&intake);
  EXPECT_EQ(r.outcome, IntakeOutcome::kSkewedPair);
  EXPECT_TRUE(r.refused());
  EXPECT_NE(r.reason.find("frame rejected: left and right image stamps differ by -0.1"),
            std::string::npos)
      << r.reason;
  EXPECT_NE(r.reason.find("sync/max_stereo_skew 0.02"), std::string::npos) << r.reason;

  // Within the limit it is one pair; the refused set did not count as a candidate.
  MessageSet close(200.01);
  close.right.header.stamp = ros::Time(200.01 + 0.015);
  r = close.into(&intake);
  EXPECT_EQ(r.outcome, IntakeOutcome::kCandidate) << r.reason;
}

TEST(FrameIntake, AnUnsynchronisedCloudIsRefusedByTheCalibrator) {
  // The LiDAR stamp is the cloud's, the frame's the left image's: the calibrator refuses a pair
  // further apart than sync/max_skew, whichever caller hands it the candidate.
  OnlineSettings settings;
  MessageSet late(300.0);
  late.cloud.header.stamp = ros::Time(300.2);
  const auto owner = startedIntake(settings, late);
  FrameIntake& intake = *owner;
  const IntakeResult r = late.into(&intake);
  ASSERT_EQ(r.outcome, IntakeOutcome::kCandidate) << r.reason;
  EXPECT_DOUBLE_EQ(r.candidate.lidar_stamp, 300.2);

  StereoRig rig;
  std::string error;
  ASSERT_TRUE(ros_conv::stereoFromCameraInfo(late.left_info, late.right_info, true, &rig, &error))
      << error;
  OnlineCalibrator calibrator(rig, settings);
  std::string msg;
  EXPECT_EQ(r.candidate.addTo(&calibrator, &msg), FrameResult::kRejected);
  EXPECT_NE(msg.find("LiDAR and image stamps differ by 0.2"), std::string::npos) << msg;
}

TEST(FrameIntake, MalformedCloudsAndImagesAreRefusedWithTheirReason) {
  OnlineSettings settings;
  MessageSet broken_cloud(400.0);
  const auto owner = startedIntake(settings, broken_cloud);
  FrameIntake& intake = *owner;
  broken_cloud.cloud.fields.erase(broken_cloud.cloud.fields.begin());  // no "x"
  IntakeResult r = broken_cloud.into(&intake);
  EXPECT_EQ(r.outcome, IntakeOutcome::kBadCloud);
  EXPECT_EQ(r.reason.rfind("point cloud rejected: ", 0), 0u) << r.reason;
  EXPECT_FALSE(r.cloud_converted);

  MessageSet bayer(400.1);
  bayer.right.encoding = "bayer_rggb8";
  r = bayer.into(&intake);
  EXPECT_EQ(r.outcome, IntakeOutcome::kBadImages);
  EXPECT_EQ(r.reason.rfind("image rejected: ", 0), 0u) << r.reason;
  EXPECT_TRUE(r.cloud_converted);  // the cloud was read before the images

  MessageSet truncated(400.2);
  truncated.left.data.resize(truncated.left.data.size() / 2);
  r = truncated.into(&intake);
  EXPECT_EQ(r.outcome, IntakeOutcome::kBadImages) << r.reason;

  // Refused sets do not advance the selection: the next set is still a candidate.
  r = MessageSet(400.3).into(&intake);
  EXPECT_EQ(r.outcome, IntakeOutcome::kCandidate) << r.reason;
  // A broken cloud that is no candidate anyway is skipped, not refused.
  MessageSet too_soon(400.4);
  too_soon.cloud.fields.clear();
  EXPECT_EQ(too_soon.into(&intake).outcome, IntakeOutcome::kNotCandidate);
}

TEST(FrameIntake, ACameraInfoChangedSinceTheStartIsSaid) {
  OnlineSettings settings;
  MessageSet set(500.0);
  const auto owner = startedIntake(settings, set);
  FrameIntake& intake = *owner;
  EXPECT_FALSE(set.into(&intake).camera_info_changed);
  MessageSet resized(501.0);
  resized.right_info.P[3] = -30.0;  // another baseline
  const IntakeResult r = resized.into(&intake);
  EXPECT_TRUE(r.camera_info_changed);
  EXPECT_EQ(r.outcome, IntakeOutcome::kCandidate);  // said, not refused: the start's rig is kept
  MessageSet stamp_only(502.0);
  stamp_only.left_info.header.seq = 7;  // what the rig is not made from does not count
  EXPECT_FALSE(stamp_only.into(&intake).camera_info_changed);
}

TEST(FrameIntake, DeskewingKeepsEverySetsScanForTheNextCandidate) {
  OnlineSettings settings;
  settings.deskew = true;
  const MessageSet first(600.0);
  const auto owner = startedIntake(settings, first);
  FrameIntake& intake = *owner;
  IntakeResult r = first.into(&intake);
  ASSERT_EQ(r.outcome, IntakeOutcome::kCandidate) << r.reason;
  EXPECT_FALSE(r.candidate.previous_scan);  // nothing before the first set

  // Not a candidate, but its scan is read and kept (a skewed pair is not checked for it).
  MessageSet between(600.1);
  between.right.header.stamp = ros::Time(599.0);
  r = between.into(&intake);
  EXPECT_EQ(r.outcome, IntakeOutcome::kNotCandidate);
  EXPECT_TRUE(r.cloud_converted);
  EXPECT_FALSE(r.candidate.previous_scan);

  r = MessageSet(600.5).into(&intake);
  ASSERT_EQ(r.outcome, IntakeOutcome::kCandidate) << r.reason;
  ASSERT_TRUE(r.candidate.previous_scan);
  EXPECT_DOUBLE_EQ(r.candidate.previous_stamp, 600.1);
  EXPECT_EQ(r.candidate.previous_scan->size(), r.candidate.frame.scan.size());
}

TEST(FrameIntake, FewRingsAndRecoveredRingsAreSaid) {
  OnlineSettings settings;
  MessageSet sparse(700.0, 16);
  const auto owner = startedIntake(settings, sparse);
  FrameIntake& intake = *owner;
  IntakeResult r = sparse.into(&intake);
  ASSERT_EQ(r.outcome, IntakeOutcome::kCandidate) << r.reason;
  EXPECT_EQ(r.rings, 16);
  EXPECT_NE(ringCountNote(r.rings).find("the LiDAR has 16 rings: its mesh is sparser"),
            std::string::npos);
  EXPECT_NE(ringCountNote(8).find("its mesh has few faces in view"), std::string::npos);
  EXPECT_EQ(ringCountNote(64), "");
  EXPECT_FALSE(r.ring_recovered);

  MessageSet no_ring(701.0);
  no_ring.cloud.fields.pop_back();  // the ring field: KITTI-style clouds
  r = no_ring.into(&intake);
  ASSERT_EQ(r.outcome, IntakeOutcome::kCandidate) << r.reason;
  EXPECT_TRUE(r.ring_recovered);
  EXPECT_EQ(r.rings, -1);  // counted once
}
