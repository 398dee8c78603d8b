#include "tescalib/ros/kitti_bag_writer.h"

#include <geometry_msgs/TransformStamped.h>
#include <rosbag/bag.h>
#include <tf2_msgs/TFMessage.h>
#include <boost/make_shared.hpp>

#include "tescalib/ros/conversions.h"

namespace tescalib {

void writeKittiBag(const KittiSequence& seq, const std::string& bag_path, const KittiBagOptions& o,
                   const std::function<void(size_t, size_t)>& progress) {
  writeKittiBag(std::vector<const KittiSequence*>{&seq}, bag_path, o, progress);
}

void writeKittiBag(const std::vector<const KittiSequence*>& seqs, const std::string& bag_path,
                   const KittiBagOptions& o, const std::function<void(size_t, size_t)>& progress) {
  if (seqs.empty()) return;
  const KittiSequence& seq = *seqs.front();
  double offset = seq.layout() == KittiLayout::kOdometry ? o.odometry_start_stamp : 0.0;
  const StereoRig& rig = seq.rig();
  size_t total = 0;
  for (const KittiSequence* s : seqs)
    total += o.max_frames < 0 ? s->size() : std::min(s->size(), static_cast<size_t>(o.max_frames));

  rosbag::Bag bag(bag_path, rosbag::bagmode::Write);
  bag.setCompression(rosbag::compression::LZ4);

  // Static transforms: base_link -> velo_link (identity: the LiDAR is the vehicle reference here)
  // and velo_link -> both cameras (the dataset's calibration, i.e. the ground truth).
  const ros::Time t0(seq.stamp(0) + offset);
  tf2_msgs::TFMessage tf_static;
  auto add = [&](const std::string& parent, const std::string& child, const Eigen::Isometry3d& T) {
    geometry_msgs::TransformStamped ts;
    ts.header.stamp = t0;
    ts.header.frame_id = parent;
    ts.child_frame_id = child;
    ts.transform = ros_conv::toTransformMsg(T);
    tf_static.transforms.push_back(ts);
  };
  add(o.base_frame, o.velo_frame, Eigen::Isometry3d::Identity());
  add(o.velo_frame, o.left_frame, rig.T_cam_lidar.inverse());
  add(o.velo_frame, o.right_frame, (rig.T_right_left * rig.T_cam_lidar).inverse());
  // Latched, and repeated with every frame as kitti2bag does, so a late subscriber gets it.
  auto latched = boost::make_shared<ros::M_string>();
  (*latched)["latching"] = "1";
  (*latched)["callerid"] = "/kitti_to_bag";
  (*latched)["type"] = ros::message_traits::datatype<tf2_msgs::TFMessage>();
  (*latched)["md5sum"] = ros::message_traits::md5sum<tf2_msgs::TFMessage>();
  (*latched)["message_definition"] = ros::message_traits::definition<tf2_msgs::TFMessage>();

  // camera_info's P as kitti2bag writes it: the dataset's P2 and P3, fourth columns included
  // (both cameras' positions measured from cam0; stereoFromCameraInfo takes their difference).
  const Eigen::Vector3d p3_left = seq.calib().P[2].col(3), p3_right = seq.calib().P[3].col(3);
  size_t written = 0;
  for (size_t si = 0; si < seqs.size(); ++si) {
    const KittiSequence& cur = *seqs[si];
    if (si > 0 && cur.layout() == KittiLayout::kOdometry)
      offset = seqs[si - 1]->stamp(seqs[si - 1]->size() - 1) + offset + 1.0 - cur.stamp(0);
    const size_t n =
        o.max_frames < 0 ? cur.size() : std::min(cur.size(), static_cast<size_t>(o.max_frames));
    for (size_t i = 0; i < n; ++i) {
      const Frame f = cur.load(i);
      const ros::Time stamp(f.stamp + offset);
      std_msgs::Header h;
      h.stamp = stamp;
      h.seq = static_cast<uint32_t>(written);

      for (auto& t : tf_static.transforms) t.header.stamp = stamp;
      bag.write("/tf_static", stamp, tf_static, latched);

      h.frame_id = o.velo_frame;
      bag.write(o.velo_topic, stamp, ros_conv::toPointCloud2(f.scan, h));

      h.frame_id = o.left_frame;
      bag.write(o.left_prefix + "/image_raw", stamp, ros_conv::toImageMsg(f.left, h, "rgb8"));
      bag.write(o.left_prefix + "/camera_info", stamp, ros_conv::toCameraInfo(rig.left, p3_left, h));

      h.frame_id = o.right_frame;
      bag.write(o.right_prefix + "/image_raw", stamp, ros_conv::toImageMsg(f.right, h, "rgb8"));
      bag.write(o.right_prefix + "/camera_info", stamp,
                ros_conv::toCameraInfo(rig.right, p3_right, h));
      ++written;
      if (progress) progress(written, total);
    }
  }
  bag.close();
}

}  // namespace tescalib
