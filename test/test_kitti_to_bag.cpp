// kitti_to_bag round trip, reading a bag's synchronized sets, and the ROS conversions, without a
// master.
#include <array>
#include <cmath>
#include <set>
#include <vector>

#include <cstring>

#include <cv_bridge/cv_bridge.h>
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/image_encodings.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <tf2_msgs/TFMessage.h>
#include <opencv2/imgcodecs.hpp>

#include "tescalib/core/common/error.h"
#include "tescalib/core/common/geometry.h"
#include "tescalib/core/sim/simulator.h"
#include "tescalib/core/uncertainty/trust.h"
#include "tescalib/ros/bag_sets.h"
#include "tescalib/ros/compressed_image.h"
#include "tescalib/ros/conversions.h"
#include "tescalib/ros/kitti_bag_writer.h"
#include "test_util.h"

using namespace tescalib;
using tescalib_test::TempDir;

TEST(KittiToBag, RoundTripMatchesTheSequence) {
  TempDir tmp;
  const std::string seq_dir = tmp.str() + "/seq";
  tescalib_test::writeSyntheticSequence(seq_dir, 3);
  const KittiSequence seq(seq_dir);
  const std::string bag_path = tmp.str() + "/out.bag";
  writeKittiBag(seq, bag_path);

  rosbag::Bag bag(bag_path, rosbag::bagmode::Read);
  std::map<std::string, int> counts;
  int cloud_i = 0, left_i = 0, right_i = 0;
  sensor_msgs::CameraInfo left_info, right_info;
  for (const rosbag::MessageInstance& m : rosbag::View(bag)) {
    ++counts[m.getTopic()];
    if (m.getTopic() == "/kitti/velo/pointcloud") {
      const auto msg = m.instantiate<sensor_msgs::PointCloud2>();
      ASSERT_TRUE(msg);
      EXPECT_EQ(msg->header.frame_id, "velo_link");
      LidarScan scan;
      std::string err;
      bool recovered = true;
      ASSERT_TRUE(ros_conv::fromPointCloud2(*msg, &scan, &err, &recovered)) << err;
      EXPECT_FALSE(recovered);  // the bag carries the ring field
      const Frame f = seq.load(cloud_i);
      ASSERT_EQ(scan.size(), f.scan.size());
      for (size_t k = 0; k < scan.size(); k += 97) {
        EXPECT_EQ(scan[k].x, f.scan[k].x);
        EXPECT_EQ(scan[k].z, f.scan[k].z);
        EXPECT_EQ(scan[k].intensity, f.scan[k].intensity);
        EXPECT_EQ(scan[k].ring, f.scan[k].ring);
      }
      EXPECT_NEAR(msg->header.stamp.toSec() - KittiBagOptions().odometry_start_stamp,
                  seq.stamp(cloud_i), 1e-6);
      ++cloud_i;
    } else if (m.getTopic() == "/kitti/camera_color_left/image_raw" ||
               m.getTopic() == "/kitti/camera_color_right/image_raw") {
      const bool left = m.getTopic() == "/kitti/camera_color_left/image_raw";
      const auto msg = m.instantiate<sensor_msgs::Image>();
      ASSERT_TRUE(msg);
      EXPECT_EQ(msg->encoding, "rgb8");
      EXPECT_EQ(msg->header.frame_id, left ? "camera_color_left" : "camera_color_right");
      cv::Mat bgr;
      std::string err;
      ASSERT_TRUE(ros_conv::toBgr8(*msg, &bgr, &err)) << err;
      const Frame f = seq.load(left ? left_i++ : right_i++);
      ASSERT_GT(cv::norm(f.left, f.right, cv::NORM_INF), 0.0);  // a swap would show
      EXPECT_EQ(cv::norm(bgr, left ? f.left : f.right, cv::NORM_INF), 0.0);
    } else if (m.getTopic() == "/kitti/camera_color_right/camera_info") {
      const auto msg = m.instantiate<sensor_msgs::CameraInfo>();
      ASSERT_TRUE(msg);
      EXPECT_EQ(msg->width, 640u);
      for (int c = 0; c < 4; ++c) EXPECT_EQ(msg->P[c], seq.calib().P[3](0, c));  // as kitti2bag
      right_info = *msg;
    } else if (m.getTopic() == "/kitti/camera_color_left/camera_info") {
      const auto msg = m.instantiate<sensor_msgs::CameraInfo>();
      ASSERT_TRUE(msg);
      left_info = *msg;
    } else if (m.getTopic() == "/tf_static") {
      const auto msg = m.instantiate<tf2_msgs::TFMessage>();
      ASSERT_TRUE(msg);
      ASSERT_EQ(msg->transforms.size(), 3u);
      const auto& t = msg->transforms[1];
      EXPECT_EQ(t.header.frame_id, "velo_link");
      EXPECT_EQ(t.child_frame_id, "camera_color_left");
      // tf convention: the transform maps child (camera) points into the parent (LiDAR).
      EXPECT_LT(poseError(ros_conv::fromTransformMsg(t.transform).inverse(), seq.rig().T_cam_lidar)
                    .norm(),
                1e-6);
    }
  }
  EXPECT_EQ(counts["/kitti/velo/pointcloud"], 3);
  EXPECT_EQ(counts["/kitti/camera_color_left/image_raw"], 3);
  EXPECT_EQ(counts["/kitti/camera_color_left/camera_info"], 3);
  EXPECT_EQ(counts["/kitti/camera_color_right/image_raw"], 3);
  EXPECT_EQ(counts["/kitti/camera_color_right/camera_info"], 3);
  EXPECT_EQ(counts["/tf_static"], 3);  // with every frame, latched, like kitti2bag
  // What the node reads back from the camera_infos is the sequence's own left-right extrinsic.
  StereoRig back;
  std::string err;
  ASSERT_TRUE(ros_conv::stereoFromCameraInfo(left_info, right_info, true, &back, &err)) << err;
  EXPECT_LT(poseError(back.T_right_left, seq.rig().T_right_left).norm(), 1e-9);
}

TEST(KittiToBag, ConvertsGeneratedSequences) {
  // tescalib_simulate's output is a KITTI odometry folder: kitti_to_bag must take it as it is.
  TempDir tmp;
  SimOptions o;
  o.frames = 2;
  o.seed = 3;
  const Simulator sim(o);
  sim.writeSequence(tmp.str() + "/seq");
  const KittiSequence seq(tmp.str() + "/seq");
  writeKittiBag(seq, tmp.str() + "/sim.bag");
  rosbag::Bag bag(tmp.str() + "/sim.bag", rosbag::bagmode::Read);
  std::map<std::string, int> counts;
  sensor_msgs::CameraInfo left_info, right_info;
  for (const rosbag::MessageInstance& m : rosbag::View(bag)) {
    ++counts[m.getTopic()];
    if (m.getTopic() == "/kitti/velo/pointcloud") {
      const auto msg = m.instantiate<sensor_msgs::PointCloud2>();
      ASSERT_TRUE(msg);
      LidarScan scan;
      std::string err;
      ASSERT_TRUE(ros_conv::fromPointCloud2(*msg, &scan, &err)) << err;
      EXPECT_EQ(scan.size(), sim.renderScan(counts[m.getTopic()] - 1).size());
      std::set<int> rings;
      for (const auto& p : scan) rings.insert(p.ring);
      EXPECT_EQ(rings.size(), 64u);
    } else if (m.getTopic() == "/kitti/camera_color_left/camera_info") {
      const auto msg = m.instantiate<sensor_msgs::CameraInfo>();
      ASSERT_TRUE(msg);
      EXPECT_EQ(msg->width, 1241u);
      EXPECT_EQ(msg->height, 376u);
      EXPECT_DOUBLE_EQ(msg->P[0], 718.856);
      left_info = *msg;
    } else if (m.getTopic() == "/kitti/camera_color_right/camera_info") {
      right_info = *m.instantiate<sensor_msgs::CameraInfo>();
    } else if (m.getTopic() == "/tf_static") {
      const auto msg = m.instantiate<tf2_msgs::TFMessage>();
      ASSERT_TRUE(msg);
      ASSERT_EQ(msg->transforms.size(), 3u);
      EXPECT_LT(poseError(ros_conv::fromTransformMsg(msg->transforms[1].transform).inverse(),
                          sim.rig().T_cam_lidar)
                    .norm(),
                1e-6);
    }
  }
  EXPECT_EQ(counts["/kitti/velo/pointcloud"], 2);
  EXPECT_EQ(counts["/kitti/camera_color_right/image_raw"], 2);
  // The generator's left camera sits beside cam0 as KITTI's does (P2[0,3] != 0): the baseline is
  // the difference of the two P's fourth columns, not the right one's alone.
  EXPECT_NE(left_info.P[3], 0.0);
  StereoRig back;
  std::string err;
  ASSERT_TRUE(ros_conv::stereoFromCameraInfo(left_info, right_info, true, &back, &err)) << err;
  EXPECT_LT(poseError(back.T_right_left, sim.rig().T_right_left).norm(), 1e-9);
}

TEST(KittiToBag, EachFolderStartsASecondAfterTheLastFrameWritten) {
  // Two folders of 4 frames (0.1 s apart), 2 written of each: the second starts 1 s after the
  // first's last written frame (it counted from the folder's last frame: 1.2 s).
  TempDir tmp;
  tescalib_test::writeSyntheticSequence(tmp.str() + "/a", 4);
  tescalib_test::writeSyntheticSequence(tmp.str() + "/b", 4);
  const KittiSequence a(tmp.str() + "/a"), b(tmp.str() + "/b");
  KittiBagOptions o;
  o.max_frames = 2;
  writeKittiBag({&a, &b}, tmp.str() + "/ab.bag", o);
  rosbag::Bag bag(tmp.str() + "/ab.bag", rosbag::bagmode::Read);
  std::vector<double> stamps;
  for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery(o.velo_topic)))
    stamps.push_back(m.instantiate<sensor_msgs::PointCloud2>()->header.stamp.toSec() -
                     o.odometry_start_stamp);
  ASSERT_EQ(stamps.size(), 4u);
  EXPECT_NEAR(stamps[0], 0.0, 1e-6);
  EXPECT_NEAR(stamps[1], 0.1, 1e-6);
  EXPECT_NEAR(stamps[2], 1.1, 1e-6);
  EXPECT_NEAR(stamps[3], 1.2, 1e-6);
}

TEST(KittiToBag, RawDrivesKeepTheirStampsUnlessTheyWouldGoBackwards) {
  // Two raw drives 5 min apart. In recording order the second keeps its epoch stamps; given
  // first, the later drive makes the earlier one start 1 s after it (a negative offset aborted
  // kitti_to_bag: ros::Time below 0).
  TempDir tmp;
  tescalib_test::writeSyntheticRawDrive(tmp.path, "a",
                                        {"2011-09-26 13:02:25.5", "2011-09-26 13:02:25.6"});
  tescalib_test::writeSyntheticRawDrive(tmp.path, "b",
                                        {"2011-09-26 13:07:25.5", "2011-09-26 13:07:25.6"});
  const KittiSequence a(tmp.str() + "/a"), b(tmp.str() + "/b");
  auto stamps = [&](const std::vector<const KittiSequence*>& seqs) {
    writeKittiBag(seqs, tmp.str() + "/raw.bag");
    rosbag::Bag bag(tmp.str() + "/raw.bag", rosbag::bagmode::Read);
    std::vector<double> out;
    for (const rosbag::MessageInstance& m :
         rosbag::View(bag, rosbag::TopicQuery(KittiBagOptions().velo_topic)))
      out.push_back(m.instantiate<sensor_msgs::PointCloud2>()->header.stamp.toSec());
    return out;
  };
  const std::vector<double> in_order = stamps({&a, &b});
  ASSERT_EQ(in_order.size(), 4u);
  EXPECT_NEAR(in_order[0], a.stamp(0), 1e-6);
  EXPECT_NEAR(in_order[2], b.stamp(0), 1e-6);  // its own epoch stamp, 300 s later
  EXPECT_NEAR(in_order[2] - in_order[1], 299.9, 1e-5);
  const std::vector<double> reversed = stamps({&b, &a});
  ASSERT_EQ(reversed.size(), 4u);
  EXPECT_NEAR(reversed[0], b.stamp(0), 1e-6);
  EXPECT_NEAR(reversed[2] - reversed[1], 1.0, 1e-5);  // not 300 s back
  EXPECT_NEAR(reversed[3] - reversed[2], 0.1, 1e-5);
}

TEST(Conversions, BaselineFromKitti2bagCameraInfos) {
  // kitti2bag writes KITTI's P_rect_02 / P_rect_03 (2011_09_26 here) into camera_info: both
  // measured from cam0. The pair's translation is K^-1 (P3[:,3] - P2[:,3]), 0.5327 m with 2.8 mm
  // vertically; the right P[3] alone would give 0.4706 m.
  sensor_msgs::CameraInfo left, right;
  left.width = right.width = 1242;
  left.height = right.height = 375;
  left.P = {7.215377e+02,
            0,
            6.095593e+02,
            4.485728e+01,
            0,
            7.215377e+02,
            1.728540e+02,
            2.163791e-01,
            0,
            0,
            1,
            2.745884e-03};
  right.P = {7.215377e+02,
             0,
             6.095593e+02,
             -3.395242e+02,
             0,
             7.215377e+02,
             1.728540e+02,
             2.199936e+00,
             0,
             0,
             1,
             2.729905e-03};
  StereoRig rig;
  std::string err;
  ASSERT_TRUE(ros_conv::stereoFromCameraInfo(left, right, true, &rig, &err)) << err;
  const Eigen::Vector3d t = rig.T_right_left.translation();
  EXPECT_NEAR(t.x(), -0.53272, 2e-5);
  EXPECT_NEAR(t.y(), 0.002755, 2e-5);
  EXPECT_NEAR(t.z(), -0.000016, 2e-6);
  EXPECT_TRUE(rig.T_right_left.linear().isIdentity());
  // ROS's convention (stereo_image_proc): left P[3] = 0, right P[3] = -fx * baseline.
  left.P[3] = left.P[7] = left.P[11] = right.P[7] = right.P[11] = 0;
  right.P[3] = -7.215377e+02 * 0.12;
  ASSERT_TRUE(ros_conv::stereoFromCameraInfo(left, right, true, &rig, &err)) << err;
  EXPECT_LT((rig.T_right_left.translation() - Eigen::Vector3d(-0.12, 0, 0)).norm(), 1e-12);
  // Left and right swapped: the "right" camera sits to the left.
  EXPECT_FALSE(ros_conv::stereoFromCameraInfo(right, left, true, &rig, &err));
  EXPECT_NE(err.find("must sit to the right of the left one"), std::string::npos) << err;
  // A right camera_info without its baseline next to a KITTI-style left one (P[3] of its offset
  // from the reference camera): not a 6 cm baseline.
  {
    sensor_msgs::CameraInfo l = left, r = right;
    l.P[3] = 7.215377e+02 * 0.06, r.P[3] = 0;
    EXPECT_FALSE(ros_conv::stereoFromCameraInfo(l, r, true, &rig, &err));
    EXPECT_NE(err.find("the right camera_info holds no baseline"), std::string::npos) << err;
  }
  // A vertical pair (KITTI-style P: both measured from a reference camera, the right one 0.5 m
  // below and 6 cm beside the left one) cannot be matched along rows.
  left.P[3] = 7.215377e+02 * 0.2;
  right.P[3] = 7.215377e+02 * 0.14, right.P[7] = -7.215377e+02 * 0.5;
  EXPECT_FALSE(ros_conv::stereoFromCameraInfo(left, right, true, &rig, &err));
  EXPECT_NE(err.find("not side by side"), std::string::npos) << err;
}

TEST(Conversions, ReadsKitti2bagClouds) {
  // kitti2bag's clouds: float32 x y z i, no ring field (recovered from the scan order).
  sensor_msgs::PointCloud2 msg;
  sensor_msgs::PointCloud2Modifier mod(msg);
  mod.setPointCloud2Fields(
      4, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1, sensor_msgs::PointField::FLOAT32, "z", 1,
      sensor_msgs::PointField::FLOAT32, "i", 1, sensor_msgs::PointField::FLOAT32);
  mod.resize(3);
  sensor_msgs::PointCloud2Iterator<float> x(msg, "x"), i(msg, "i");
  for (int k = 0; k < 3; ++k, ++x, ++i) {
    x[0] = 10.f + k, x[1] = 0.5f * k, x[2] = -1.f;
    *i = 0.25f * k;
  }
  LidarScan scan;
  std::string err;
  bool recovered = false;
  ASSERT_TRUE(ros_conv::fromPointCloud2(msg, &scan, &err, &recovered)) << err;
  ASSERT_EQ(scan.size(), 3u);
  EXPECT_TRUE(recovered);
  EXPECT_EQ(scan[2].x, 12.f);
  EXPECT_EQ(scan[2].intensity, 0.5f);
}

TEST(KittiToBag, RealKittiCameraInfosGiveTheSequencesBaseline) {
  SKIP_WITHOUT_KITTI();
  // KITTI's rectified pair is not rectified along x alone: 2011_09_30's right camera sits 3.3 mm
  // off vertically (its P3). Through the bag it must be what the folder gives.
  TempDir tmp;
  const KittiSequence seq(tescalib_test::kittiDir() + "/sequences/04");
  KittiBagOptions o;
  o.max_frames = 1;
  writeKittiBag(seq, tmp.str() + "/04.bag", o);
  rosbag::Bag bag(tmp.str() + "/04.bag", rosbag::bagmode::Read);
  sensor_msgs::CameraInfo left, right;
  for (const rosbag::MessageInstance& m : rosbag::View(bag)) {
    if (m.getTopic() == "/kitti/camera_color_left/camera_info")
      left = *m.instantiate<sensor_msgs::CameraInfo>();
    if (m.getTopic() == "/kitti/camera_color_right/camera_info")
      right = *m.instantiate<sensor_msgs::CameraInfo>();
  }
  StereoRig back;
  std::string err;
  ASSERT_TRUE(ros_conv::stereoFromCameraInfo(left, right, true, &back, &err)) << err;
  const Eigen::Vector3d t = back.T_right_left.translation();
  std::cout << "[ kitti 04 ] camera_info baseline " << t.transpose() << " m\n";
  EXPECT_LT((t - seq.rig().T_right_left.translation()).norm(), 1e-9);
  EXPECT_GT(std::abs(t.y()), 0.002);
  EXPECT_NEAR(t.norm(), 0.5327, 0.003);
}

TEST(BagSets, EachCloudTakesTheNearestImagesWithinTheSkew) {
  // A bag as a real recording has it: images a few milliseconds off the cloud, recorded out of
  // stamp order, one right image missing its cloud's tolerance, camera_info once at the start.
  TempDir tmp;
  const std::string path = tmp.str() + "/sets.bag";
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    auto stamped = [](auto msg, double t) {
      msg.header.stamp = ros::Time(t);
      return msg;
    };
    const BagTopics topics;
    sensor_msgs::CameraInfo info;
    bag.write(topics.left_info, ros::Time(99.9), stamped(info, 99.9));
    bag.write(topics.right_info, ros::Time(99.9), stamped(info, 99.9));
    const double clouds[] = {100.0, 100.1, 100.2, 100.3};
    const double lefts[] = {100.01, 100.11, 100.21, 100.31};
    const double rights[] = {99.98, 100.1, 100.28};  // nothing within 0.05 s of 100.2
    for (double t : clouds)
      bag.write(topics.points, ros::Time(t + 0.03), stamped(sensor_msgs::PointCloud2(), t));
    for (double t : lefts)
      bag.write(topics.left, ros::Time(t + 0.02), stamped(sensor_msgs::Image(), t));
    for (double t : rights) bag.write(topics.right, ros::Time(t), stamped(sensor_msgs::Image(), t));
  }
  std::vector<std::array<double, 3>> sets;
  const BagCounts n = readBagSets(path, BagTopics{}, [&](const BagSet& set) {
    ASSERT_TRUE(set.left_info && set.right_info);
    sets.push_back({set.cloud->header.stamp.toSec(), set.left->header.stamp.toSec(),
                    set.right->header.stamp.toSec()});
  });
  EXPECT_EQ(n.clouds, 4);
  EXPECT_EQ(n.left, 4);
  EXPECT_EQ(n.right, 3);
  EXPECT_EQ(n.sets, 3);
  EXPECT_EQ(n.unmatched_clouds, 1);
  ASSERT_EQ(sets.size(), 3u);
  const double expected[3][3] = {
      {100.0, 100.01, 99.98}, {100.1, 100.11, 100.1}, {100.3, 100.31, 100.28}};
  for (size_t i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(sets[i][k], expected[i][k], 1e-6) << i << " " << k;
  BagTopics elsewhere;
  elsewhere.points = "/velodyne_points";
  EXPECT_THROW(readBagSets(path, elsewhere, [](const BagSet&) {}), DataError);
  EXPECT_THROW(readBagSets(tmp.str() + "/missing.bag", BagTopics{}, [](const BagSet&) {}),
               DataError);
}

TEST(BagSets, CompressedImagesAreReadAsTheImagesTheyHold) {
  // image_transport's compressed topics (PNG here, lossless): decoded to bgr8 / mono8 with their
  // headers; data that is not an image is left out and counted.
  TempDir tmp;
  const std::string path = tmp.str() + "/compressed.bag";
  cv::Mat colour(6, 8, CV_8UC3), grey(6, 8, CV_8UC1);
  cv::randu(colour, 0, 256);
  cv::randu(grey, 0, 256);
  BagTopics topics;
  topics.left = "/cam/left/image_rect/compressed";
  topics.right = "/cam/right/image_rect/compressed";
  topics.left_info = "/cam/left/camera_info";
  topics.right_info = "/cam/right/camera_info";
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    auto compressed = [](const cv::Mat& image, double t) {
      sensor_msgs::CompressedImage msg;
      msg.header.stamp = ros::Time(t);
      msg.header.frame_id = "cam";
      msg.format = "png";
      cv::imencode(".png", image, msg.data);
      return msg;
    };
    sensor_msgs::CameraInfo info;
    info.header.stamp = ros::Time(99.9);
    bag.write(topics.left_info, ros::Time(99.9), info);
    bag.write(topics.right_info, ros::Time(99.9), info);
    for (double t : {100.0, 100.1}) {
      sensor_msgs::PointCloud2 cloud;
      cloud.header.stamp = ros::Time(t);
      bag.write(topics.points, ros::Time(t), cloud);
      bag.write(topics.left, ros::Time(t), compressed(colour, t));
      bag.write(topics.right, ros::Time(t), compressed(grey, t));
    }
    sensor_msgs::CompressedImage broken = compressed(colour, 100.2);
    broken.data.resize(10);  // a truncated PNG
    bag.write(topics.left, ros::Time(100.2), broken);
  }
  int sets = 0;
  const BagCounts n = readBagSets(path, topics, [&](const BagSet& set) {
    ++sets;
    ASSERT_TRUE(set.left && set.right);
    EXPECT_EQ(set.left->encoding, sensor_msgs::image_encodings::BGR8);
    EXPECT_EQ(set.right->encoding, sensor_msgs::image_encodings::MONO8);
    EXPECT_EQ(set.left->header.frame_id, "cam");
    EXPECT_NEAR(set.left->header.stamp.toSec(), set.cloud->header.stamp.toSec(), 1e-9);
    EXPECT_EQ(cv::norm(cv_bridge::toCvCopy(set.left)->image, colour, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(cv_bridge::toCvCopy(set.right)->image, grey, cv::NORM_INF), 0.0);
  });
  EXPECT_EQ(sets, 2);
  EXPECT_EQ(n.left, 2);
  EXPECT_EQ(n.right, 2);
  EXPECT_EQ(n.undecodable_images, 1);
  sensor_msgs::CompressedImage empty;
  EXPECT_FALSE(decodeCompressedImage(empty));
}

TEST(Conversions, CloudWithoutRingNaNsAndEmpty) {
  LidarScan scan = tescalib_test::syntheticScan(64, 100);
  recoverRings(scan);
  std_msgs::Header h;
  sensor_msgs::PointCloud2 msg = ros_conv::toPointCloud2(scan, h);
  // Poison two points with NaN.
  float nan = std::nanf("");
  std::memcpy(&msg.data[0 * msg.point_step], &nan, 4);
  std::memcpy(&msg.data[5 * msg.point_step + 4], &nan, 4);
  LidarScan out;
  std::string err;
  ASSERT_TRUE(ros_conv::fromPointCloud2(msg, &out, &err)) << err;
  EXPECT_EQ(out.size(), scan.size() - 2);

  // Drop the ring field: rings are recovered from scan order.
  sensor_msgs::PointCloud2 noring = ros_conv::toPointCloud2(scan, h);
  noring.fields.pop_back();
  bool recovered = false;
  ASSERT_TRUE(ros_conv::fromPointCloud2(noring, &out, &err, &recovered)) << err;
  EXPECT_TRUE(recovered);
  std::set<int> rings;
  for (const auto& p : out) rings.insert(p.ring);
  EXPECT_EQ(rings.size(), 64u);

  // No per-point time in our clouds (NaN: unknown); a raw driver's time field is read as seconds
  // from the cloud's stamp: velodyne_pointcloud's float "time", Ouster's uint32 "t" (ns).
  EXPECT_EQ(ros_conv::perPointTimeField(msg), "");
  EXPECT_TRUE(std::isnan(out[0].time));
  for (const std::string name : {"time", "t"}) {
    sensor_msgs::PointCloud2 timed;
    timed.header.stamp = ros::Time(100.0);
    sensor_msgs::PointCloud2Modifier mod(timed);
    mod.setPointCloud2Fields(
        4, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1, sensor_msgs::PointField::FLOAT32, "z",
        1, sensor_msgs::PointField::FLOAT32, name.c_str(), 1,
        name == "t" ? sensor_msgs::PointField::UINT32 : sensor_msgs::PointField::FLOAT32);
    mod.resize(scan.size());
    sensor_msgs::PointCloud2Iterator<float> x(timed, "x"), y(timed, "y"), z(timed, "z");
    for (size_t k = 0; k < scan.size(); ++k, ++x, ++y, ++z) {
      *x = scan[k].x, *y = scan[k].y, *z = scan[k].z;
      uint8_t* t = &timed.data[k * timed.point_step + timed.fields[3].offset];
      if (name == "t") {
        const uint32_t ns = static_cast<uint32_t>(k) * 1000u;  // 1 us apart
        std::memcpy(t, &ns, 4);
      } else {
        const float s = -0.05f + 1e-6f * k;
        std::memcpy(t, &s, 4);
      }
    }
    EXPECT_EQ(ros_conv::perPointTimeField(timed), name);
    ASSERT_TRUE(ros_conv::fromPointCloud2(timed, &out, &err)) << err;
    ASSERT_EQ(out.size(), scan.size());
    EXPECT_NEAR(out[10].time, name == "t" ? 10e-6 : -0.05 + 10e-6, 1e-7) << name;
  }

  sensor_msgs::PointCloud2 empty = ros_conv::toPointCloud2(LidarScan{}, h);
  EXPECT_FALSE(ros_conv::fromPointCloud2(empty, &out, &err));
  EXPECT_NE(err.find("empty"), std::string::npos) << err;
}

TEST(Conversions, ABrokenCloudLayoutIsAMessageNotACrash) {
  // Checking data.size() alone is not enough: point_step 0 with no data would read from address 0
  // (killing the nodelet manager), and a field past point_step would read beyond the buffer.
  LidarScan scan = tescalib_test::syntheticScan(16, 50);
  recoverRings(scan);
  std_msgs::Header h;
  const sensor_msgs::PointCloud2 good = ros_conv::toPointCloud2(scan, h);
  LidarScan out;
  std::string err;
  ASSERT_TRUE(ros_conv::fromPointCloud2(good, &out, &err)) << err;
  ASSERT_EQ(out.size(), scan.size());

  sensor_msgs::PointCloud2 no_step = good;
  no_step.point_step = 0, no_step.row_step = 0;
  no_step.data.clear();
  EXPECT_FALSE(ros_conv::fromPointCloud2(no_step, &out, &err));
  EXPECT_NE(err.find("layout is inconsistent"), std::string::npos) << err;

  sensor_msgs::PointCloud2 past = good;
  past.fields.back().offset = past.point_step;  // the ring field beyond the point
  EXPECT_FALSE(ros_conv::fromPointCloud2(past, &out, &err));
  EXPECT_NE(err.find("field 'ring'"), std::string::npos) << err;
  EXPECT_NE(err.find("does not fit"), std::string::npos) << err;

  sensor_msgs::PointCloud2 odd_type = good;
  odd_type.fields.front().datatype = 42;
  EXPECT_FALSE(ros_conv::fromPointCloud2(odd_type, &out, &err));
  EXPECT_NE(err.find("unknown datatype"), std::string::npos) << err;

  // Organised clouds are read row by row, with row_step's padding skipped.
  sensor_msgs::PointCloud2 organised = good;
  const uint32_t width = static_cast<uint32_t>(scan.size() / 2), pad = 8;
  organised.width = width, organised.height = 2;
  organised.row_step = width * good.point_step + pad;
  organised.data.assign(2 * organised.row_step, 0);
  for (uint32_t r = 0; r < 2; ++r)
    std::memcpy(&organised.data[r * organised.row_step], &good.data[r * width * good.point_step],
                width * good.point_step);
  ASSERT_TRUE(ros_conv::fromPointCloud2(organised, &out, &err)) << err;
  ASSERT_EQ(out.size(), 2u * width);
  EXPECT_EQ(out[width].x, scan[width].x);
  EXPECT_EQ(out[width].ring, scan[width].ring);
  // A row_step shorter than a row is not a layout.
  organised.row_step = width * good.point_step - 1;
  EXPECT_FALSE(ros_conv::fromPointCloud2(organised, &out, &err));
  EXPECT_NE(err.find("row_step"), std::string::npos) << err;
}

TEST(Conversions, ImageEncodings) {
  cv::Mat bgr(4, 6, CV_8UC3, cv::Scalar(10, 20, 30));
  std_msgs::Header h;
  cv::Mat out;
  std::string err;
  for (const std::string enc : {"bgr8", "rgb8"}) {
    ASSERT_TRUE(ros_conv::toBgr8(ros_conv::toImageMsg(bgr, h, enc), &out, &err)) << err;
    EXPECT_EQ(out.at<cv::Vec3b>(2, 3), cv::Vec3b(10, 20, 30)) << enc;
  }
  sensor_msgs::Image mono;
  cv_bridge::CvImage(h, "mono8", cv::Mat(4, 6, CV_8UC1, cv::Scalar(77))).toImageMsg(mono);
  ASSERT_TRUE(ros_conv::toBgr8(mono, &out, &err)) << err;
  EXPECT_EQ(out.type(), CV_8UC3);
  EXPECT_EQ(out.at<cv::Vec3b>(0, 0), cv::Vec3b(77, 77, 77));
  sensor_msgs::Image depth;
  cv_bridge::CvImage(h, "32FC1", cv::Mat(4, 6, CV_32FC1, cv::Scalar(1.f))).toImageMsg(depth);
  EXPECT_FALSE(ros_conv::toBgr8(depth, &out, &err));
  EXPECT_NE(err.find("32FC1"), std::string::npos) << err;
  // A Bayer image is a camera's raw output: not rectified, refused with what to remap.
  sensor_msgs::Image bayer = mono;
  bayer.encoding = "bayer_rggb8";
  EXPECT_FALSE(ros_conv::toBgr8(bayer, &out, &err));
  EXPECT_NE(err.find("image_rect_color"), std::string::npos) << err;
}

TEST(Conversions, Mono16IsScaledByTheBitsItUses) {
  // A 12-bit camera's mono16 (0-4095): divided by 256 it would keep 16 grey levels.
  std_msgs::Header h;
  cv::Mat twelve(4, 6, CV_16UC1, cv::Scalar(2000));
  twelve.at<uint16_t>(0, 0) = 4095;
  sensor_msgs::Image left, right;
  cv_bridge::CvImage(h, "mono16", twelve).toImageMsg(left);
  cv::Mat out;
  std::string err;
  ASSERT_TRUE(ros_conv::toBgr8(left, &out, &err)) << err;
  EXPECT_EQ(out.at<cv::Vec3b>(0, 0), cv::Vec3b(255, 255, 255));
  EXPECT_EQ(out.at<cv::Vec3b>(1, 1)[0], 125);  // 2000 * 255 / 4095 = 124.5
  // Full 16-bit range: / 257.
  cv::Mat sixteen = twelve * 16;
  sixteen.at<uint16_t>(0, 0) = 65535;
  cv_bridge::CvImage(h, "mono16", sixteen).toImageMsg(right);
  ASSERT_TRUE(ros_conv::toBgr8(right, &out, &err)) << err;
  EXPECT_EQ(out.at<cv::Vec3b>(1, 1)[0], 125);  // 32000 / 257 = 124.5
  // A pair takes one scale for both, so that SGBM sees them alike: the brighter image's, so
  // that it does not clip whichever camera it is.
  cv::Mat darker = twelve / 2;  // its values use 11 bits
  darker.at<uint16_t>(0, 0) = 2047;
  cv_bridge::CvImage(h, "mono16", darker).toImageMsg(right);
  for (const bool left_darker : {false, true}) {
    const sensor_msgs::Image& a = left_darker ? right : left;  // the pair's left image
    const sensor_msgs::Image& b = left_darker ? left : right;
    double scale = ros_conv::mono16Scale({&a, &b});
    EXPECT_NEAR(scale, 255.0 / 4095.0, 1e-12) << left_darker;
    cv::Mat out_a, out_b;
    ASSERT_TRUE(ros_conv::toBgr8(a, &out_a, &err, &scale)) << err;
    ASSERT_TRUE(ros_conv::toBgr8(b, &out_b, &err, &scale)) << err;
    const cv::Mat& bright = left_darker ? out_b : out_a;
    const cv::Mat& dark = left_darker ? out_a : out_b;
    EXPECT_EQ(bright.at<cv::Vec3b>(0, 0)[0], 255);  // 4095: not clipped below it
    EXPECT_EQ(bright.at<cv::Vec3b>(1, 1)[0], 125);
    EXPECT_EQ(dark.at<cv::Vec3b>(1, 1)[0], 62);   // 1000 * 255 / 4095 = 62.3
    EXPECT_EQ(dark.at<cv::Vec3b>(0, 0)[0], 127);  // 2047 * 255 / 4095 = 127.5: not 255
  }
  // toBgr8Pair does the same, and names the camera of an unusable image.
  cv::Mat out_l, out_r;
  ASSERT_TRUE(ros_conv::toBgr8Pair(right, left, &out_l, &out_r, &err)) << err;
  EXPECT_EQ(out_l.at<cv::Vec3b>(1, 1)[0], 62);
  EXPECT_EQ(out_r.at<cv::Vec3b>(0, 0)[0], 255);
  sensor_msgs::Image float_image = right;
  float_image.encoding = "32FC1";
  EXPECT_FALSE(ros_conv::toBgr8Pair(left, float_image, &out_l, &out_r, &err));
  EXPECT_EQ(err.rfind("right image: unsupported image encoding '32FC1'", 0), 0u) << err;
  // Alone, the darker image uses its own 11 bits; without a mono16 image there is no scale.
  EXPECT_NEAR(ros_conv::mono16Scale({&right}), 255.0 / 2047.0, 1e-12);
  sensor_msgs::Image colour;
  cv_bridge::CvImage(h, "bgr8", cv::Mat(4, 6, CV_8UC3, cv::Scalar(1, 2, 3))).toImageMsg(colour);
  EXPECT_EQ(ros_conv::mono16Scale({&colour}), 0.0);
}

TEST(Conversions, CameraInfoRoundTrip) {
  CameraIntrinsics c;
  c.fx = 718.856, c.fy = 718.856, c.cx = 607.1928, c.cy = 185.2157, c.width = 1241, c.height = 376;
  CameraIntrinsics back;
  std::string err;
  ASSERT_TRUE(ros_conv::fromCameraInfo(ros_conv::toCameraInfo(c, -386.1448, {}), &back, &err));
  EXPECT_EQ(back.fx, c.fx);
  EXPECT_EQ(back.cy, c.cy);
  EXPECT_EQ(back.width, 1241);
  sensor_msgs::CameraInfo missing;
  EXPECT_FALSE(ros_conv::fromCameraInfo(missing, &back, &err));
}

TEST(Conversions, KeyframeCloudAndMeshForRviz) {
  StereoCloud cloud;
  cloud.points.resize(3);
  for (int i = 0; i < 3; ++i) {
    cloud.points[i].p = Eigen::Vector3f(0.1f * i, -0.2f, 10.0f + i);
    cloud.points[i].disparity = 38.0f - i;
  }
  std_msgs::Header h;
  h.frame_id = "tescalib_left";
  const sensor_msgs::PointCloud2 msg = ros_conv::toPointCloud2(cloud, h);
  ASSERT_EQ(msg.width * msg.height, 3u);
  EXPECT_EQ(msg.header.frame_id, "tescalib_left");
  sensor_msgs::PointCloud2ConstIterator<float> z(msg, "z"), d(msg, "disparity");
  for (int i = 0; i < 3; ++i, ++z, ++d) {
    EXPECT_FLOAT_EQ(*z, 10.0f + i);
    EXPECT_FLOAT_EQ(*d, 38.0f - i);
  }

  LidarMesh mesh;
  for (int i = 0; i < 10; ++i) {
    MeshFace f;
    f.a = Eigen::Vector3f(5.0f + i, 0, 0), f.b = f.a + Eigen::Vector3f(0, 0.1f, 0);
    f.c = f.a + Eigen::Vector3f(0, 0, 0.1f);
    f.centroid = (f.a + f.b + f.c) / 3.0f;
    f.normal = Eigen::Vector3f(-1, 0, 0);
    f.range = 5.0f + 10.0f * i;
    mesh.faces.push_back(f);
  }
  const visualization_msgs::Marker all = ros_conv::toMeshMarker(mesh, h, 100, 40.0);
  EXPECT_EQ(all.type, visualization_msgs::Marker::TRIANGLE_LIST);
  ASSERT_EQ(all.points.size(), 30u);
  ASSERT_EQ(all.colors.size(), 30u);
  EXPECT_FLOAT_EQ(all.points[4].y, 0.1f);         // face 1, vertex b
  EXPECT_GT(all.colors[0].r, all.colors[0].b);    // 5 m: near, red
  EXPECT_GT(all.colors[27].b, all.colors[27].r);  // 95 m: beyond max_range, blue
  const visualization_msgs::Marker some = ros_conv::toMeshMarker(mesh, h, 4, 40.0);
  EXPECT_LE(some.points.size(), 12u);  // at most 4 faces
  EXPECT_EQ(some.points.size() % 3, 0u);
  EXPECT_GE(some.points.size(), 9u);
}

TEST(Conversions, AGivenExtrinsicIsNotCalledObservableOrExact) {
  // ~left_to_right without co-calibration is observable on no axis, and its pose topic does not
  // carry 36 zeros, which geometry_msgs users read as exact.
  std_msgs::Header h;
  const Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  Matrix6d cov = Matrix6d::Identity() * 1e-6;
  const bool all[6] = {true, true, true, true, true, true};
  const ExtrinsicEstimate given = ros_conv::toEstimateMsg(h, "right", "left", T, Matrix6d::Zero(),
                                                          all, true, 3, 0, 0, "", false);
  for (bool o : given.observable) EXPECT_FALSE(o);
  const ExtrinsicEstimate estimated =
      ros_conv::toEstimateMsg(h, "right", "left", T, cov, all, true, 3, 0, 0, "", true);
  for (bool o : estimated.observable) EXPECT_TRUE(o);
  EXPECT_EQ(estimated.weakest_ratio, 0.0);  // none given
  WeakDirection w;
  w.ratio = 1.5, w.direction(5) = 0.8, w.direction(3) = -0.6;
  const ExtrinsicEstimate weak =
      ros_conv::toEstimateMsg(h, "left", "lidar", T, cov, all, false, 3, 0, 0, "", true, w);
  EXPECT_EQ(weak.weakest_ratio, 1.5);
  EXPECT_EQ(weak.weakest_direction[5], 0.8);
  EXPECT_EQ(weak.weakest_direction[3], -0.6);
  EXPECT_EQ(
      ros_conv::toEstimateMsg(h, "r", "l", T, cov, all, true, 3, 0, 0, "", false, w).weakest_ratio,
      0.0);  // a given extrinsic has no weak direction of its own
  // A solve that ended before its covariance: its placeholder (identity, 57 deg / 1 m) is
  // marked unknown, not sent as an uncertainty.
  const ExtrinsicEstimate early = ros_conv::toEstimateMsg(
      h, "left", "lidar", T, Matrix6d::Identity(), all, false, 3, 0, 0, "", true, w, false);
  EXPECT_EQ(early.covariance[0], -1.0);
  EXPECT_EQ(early.covariance[7], 0.0);
  EXPECT_EQ(early.sigma_rot_deg[0], -1.0);
  EXPECT_EQ(early.sigma_trans_m[2], -1.0);
  const auto unknown = ros_conv::toPoseMsg(h, T, Matrix6d::Zero(), false);
  EXPECT_EQ(unknown.pose.covariance[0], -1.0);
  EXPECT_EQ(unknown.pose.covariance[7], 0.0);
  const auto known = ros_conv::toPoseMsg(h, T, cov, true);
  EXPECT_DOUBLE_EQ(known.pose.covariance[0], 1e-6);
  EXPECT_DOUBLE_EQ(known.pose.covariance[35], 1e-6);
}

TEST(Conversions, BinningAndRoiScaleTheIntrinsicsNotTheBaseline) {
  // A binned camera's P is scaled, and the camera is not rejected for its image size.
  CameraIntrinsics c;
  c.fx = c.fy = 700.0, c.cx = 620.0, c.cy = 180.0, c.width = 1240, c.height = 376;
  std_msgs::Header h;
  sensor_msgs::CameraInfo left = ros_conv::toCameraInfo(c, 0.0, h);
  sensor_msgs::CameraInfo right = ros_conv::toCameraInfo(c, -700.0 * 0.54, h);
  for (sensor_msgs::CameraInfo* info : {&left, &right}) {
    info->binning_x = info->binning_y = 2;
    info->roi.x_offset = 20, info->roi.y_offset = 10;
    info->roi.width = 1200, info->roi.height = 360;
  }
  StereoRig rig;
  std::string error;
  ASSERT_TRUE(ros_conv::stereoFromCameraInfo(left, right, true, &rig, &error)) << error;
  EXPECT_DOUBLE_EQ(rig.left.fx, 350.0);
  EXPECT_DOUBLE_EQ(rig.left.cx, 300.0);  // (620 - 20) / 2
  EXPECT_DOUBLE_EQ(rig.left.cy, 85.0);   // (180 - 10) / 2
  EXPECT_EQ(rig.left.width, 600);
  EXPECT_EQ(rig.left.height, 180);
  EXPECT_NEAR(rig.T_right_left.translation().x(), -0.54, 1e-12);
  left.roi.width = 1300;  // beyond the 1240 px image
  EXPECT_FALSE(ros_conv::stereoFromCameraInfo(left, right, true, &rig, &error));
  EXPECT_NE(error.find("roi lies outside"), std::string::npos) << error;
}
