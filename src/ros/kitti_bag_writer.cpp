#include "tescalib/ros/kitti_bag_writer.h"

#include <geometry_msgs/TransformStamped.h>
#include <rosbag/bag.h>
#include <tf2_msgs/TFMessage.h>
#include <algorithm>
#include <boost/make_shared.hpp>
#include <cmath>

#include "tescalib/ros/conversions.h"

namespace tescalib {

void writeKittiBag(const KittiSequence& seq, const std::string& bag_path, const KittiBagOptions& o,
                   const std::function<void(size_t, size_t)>& progress) {
  writeKittiBag(std::vector<const KittiSequence*>{&seq}, bag_path, o, progress);
}

namespace {
/// A sequence's stamp `s` (seconds, from times.txt) shifted by `offset`, to the nanosecond of its
/// decimal value: the whole seconds of the offset as integers, the rest as a short duration.
/// ros::Time(s + offset) would round through a double of about 0.24 us resolution at this epoch:
/// the bag's stamps look like a real driver's, not on a 0.24 us grid, so that a node that
/// rebuilds stamps from doubles shows.
ros::Time bagStamp(double offset, double s, uint32_t extra_nsec) {
  const double whole = std::floor(offset);
  return ros::Time(whole) + ros::Duration(offset - whole + s) + ros::Duration(0, extra_nsec);
}

/// The transforms on /tf_static, stamped `t0`: base_link -> velo_link (identity: the LiDAR is the
/// vehicle reference here) and velo_link -> both cameras (the dataset's calibration, i.e. the
/// ground truth), or kitti2bag's tree through imu_link.
tf2_msgs::TFMessage staticTransforms(const StereoRig& rig, const KittiBagOptions& o,
                                     const ros::Time& t0) {
  tf2_msgs::TFMessage tf_static;
  auto add = [&](const std::string& parent, const std::string& child, const Eigen::Isometry3d& T) {
    geometry_msgs::TransformStamped ts;
    ts.header.stamp = t0;
    ts.header.frame_id = parent;
    ts.child_frame_id = child;
    ts.transform = ros_conv::toTransformMsg(T);
    tf_static.transforms.push_back(ts);
  };
  if (o.like_kitti2bag) {
    // kitti2bag: base_link -> imu_link (T_base_link_to_imu), imu_link -> velo_link and the
    // cameras (the inverses of T_velo_imu and T_camN_imu). KITTI's T_velo_imu is about
    // (-0.81, 0.32, -0.80) m with a rotation of a few hundredths of a degree.
    Eigen::Isometry3d T_velo_imu = Eigen::Isometry3d::Identity();
    T_velo_imu.linear() =
        Eigen::AngleAxisd(0.0009, Eigen::Vector3d(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
    T_velo_imu.translation() = Eigen::Vector3d(-0.808, 0.319, -0.800);
    Eigen::Isometry3d T_base_imu = Eigen::Isometry3d::Identity();
    T_base_imu.translation() = Eigen::Vector3d(2.71, 0, 0.93);
    add(o.base_frame, o.imu_frame, T_base_imu);
    add(o.imu_frame, o.velo_frame, T_velo_imu.inverse());
    add(o.imu_frame, o.left_frame, (rig.T_cam_lidar * T_velo_imu).inverse());
    add(o.imu_frame, o.right_frame, (rig.T_right_left * rig.T_cam_lidar * T_velo_imu).inverse());
  } else {
    add(o.base_frame, o.velo_frame, Eigen::Isometry3d::Identity());
    add(o.velo_frame, o.left_frame, rig.T_cam_lidar.inverse());
    add(o.velo_frame, o.right_frame, (rig.T_right_left * rig.T_cam_lidar).inverse());
  }
  return tf_static;
}

/// Writes each frame's messages: /tf_static (latched, and repeated with every frame as kitti2bag
/// does, so a late subscriber gets it), the cloud, both images and both camera_infos.
struct FrameWriter {
  rosbag::Bag& bag;
  const KittiBagOptions& o;
  const StereoRig& rig;
  tf2_msgs::TFMessage tf_static;
  /// camera_info's P as kitti2bag writes it: the dataset's P2 and P3, fourth columns included
  /// (both cameras' positions measured from cam0; stereoFromCameraInfo takes their difference).
  Eigen::Vector3d p3_left, p3_right;
  std::string encoding;
  boost::shared_ptr<ros::M_string> latched = boost::make_shared<ros::M_string>();

  FrameWriter(rosbag::Bag& b, const KittiBagOptions& options, const KittiSequence& seq,
              const ros::Time& t0)
      : bag(b),
        o(options),
        rig(seq.rig()),
        tf_static(staticTransforms(seq.rig(), options, t0)),
        p3_left(seq.calib().P[2].col(3)),
        p3_right(seq.calib().P[3].col(3)),
        encoding(options.like_kitti2bag ? "bgr8" : "rgb8") {
    (*latched)["latching"] = "1";
    (*latched)["callerid"] = "/kitti_to_bag";
    (*latched)["type"] = ros::message_traits::datatype<tf2_msgs::TFMessage>();
    (*latched)["md5sum"] = ros::message_traits::md5sum<tf2_msgs::TFMessage>();
    (*latched)["message_definition"] = ros::message_traits::definition<tf2_msgs::TFMessage>();
  }

  void write(const Frame& f, const ros::Time& stamp, uint32_t seq) {
    std_msgs::Header h;
    h.stamp = stamp;
    h.seq = seq;

    for (auto& t : tf_static.transforms) t.header.stamp = stamp;
    bag.write("/tf_static", stamp, tf_static, latched);

    h.frame_id = o.velo_frame;
    bag.write(o.velo_topic, stamp,
              o.like_kitti2bag ? ros_conv::toPointCloud2Xyzi(f.scan, h)
                               : ros_conv::toPointCloud2(f.scan, h));

    h.frame_id = o.left_frame;
    bag.write(o.left_prefix + "/image_raw", stamp, ros_conv::toImageMsg(f.left, h, encoding));
    bag.write(o.left_prefix + "/camera_info", stamp, ros_conv::toCameraInfo(rig.left, p3_left, h));

    h.frame_id = o.right_frame;
    bag.write(o.right_prefix + "/image_raw", stamp, ros_conv::toImageMsg(f.right, h, encoding));
    bag.write(o.right_prefix + "/camera_info", stamp,
              ros_conv::toCameraInfo(rig.right, p3_right, h));
  }
};
}  // namespace

void writeKittiBag(const std::vector<const KittiSequence*>& seqs, const std::string& bag_path,
                   const KittiBagOptions& o, const std::function<void(size_t, size_t)>& progress) {
  if (seqs.empty()) return;
  const KittiSequence& seq = *seqs.front();
  double offset = seq.layout() == KittiLayout::kOdometry ? o.odometry_start_stamp : 0.0;
  size_t total = 0;
  for (const KittiSequence* s : seqs)
    total += o.max_frames < 0 ? s->size() : std::min(s->size(), static_cast<size_t>(o.max_frames));

  rosbag::Bag bag(bag_path, rosbag::bagmode::Write);
  bag.setCompression(rosbag::compression::LZ4);
  FrameWriter writer(bag, o, seq, bagStamp(offset, seq.stamp(0), o.stamp_offset_nsec));
  size_t written = 0;
  double last_written = 0;  // the last written frame's stamp in the bag (offset included)
  for (size_t si = 0; si < seqs.size(); ++si) {
    const KittiSequence& cur = *seqs[si];
    // A folder keeps its own stamps (a raw drive's epoch stamps; odometry ones shifted to start
    // at odometry_start_stamp) when they start at least 1 s after the last frame written;
    // otherwise (odometry sequences, a drive given out of order) it starts 1 s after it. The
    // offset never goes below the natural one, so it is never negative.
    if (si > 0) {
      const double natural = cur.layout() == KittiLayout::kOdometry ? o.odometry_start_stamp : 0.0;
      offset = std::max(natural, last_written + 1.0 - cur.stamp(0));
    }
    const size_t n =
        o.max_frames < 0 ? cur.size() : std::min(cur.size(), static_cast<size_t>(o.max_frames));
    if (n > 0) last_written = offset + cur.stamp(n - 1);
    for (size_t i = 0; i < n; ++i) {
      const Frame f = cur.load(i);
      writer.write(f, bagStamp(offset, f.stamp, o.stamp_offset_nsec),
                   static_cast<uint32_t>(written));
      ++written;
      if (progress) progress(written, total);
    }
  }
  bag.close();
}

}  // namespace tescalib
