#include "tescalib/ros/kitti_bag_writer.h"

#include <geometry_msgs/TransformStamped.h>
#include <rosbag/bag.h>
#include <tf2_msgs/TFMessage.h>

#include "tescalib/ros/conversions.h"

namespace tescalib {

void writeKittiBag(const KittiSequence& seq, const std::string& bag_path,
                   const KittiBagOptions& o, const std::function<void(size_t, size_t)>& progress) {
  const double offset = seq.layout() == KittiLayout::kOdometry ? o.odometry_start_stamp : 0.0;
  const size_t n = o.max_frames < 0 ? seq.size()
                                    : std::min(seq.size(), static_cast<size_t>(o.max_frames));
  const StereoRig& rig = seq.rig();

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
  bag.write("/tf_static", t0, tf_static);

  const double Tx_right = -rig.right.fx * rig.T_right_left.translation().norm();
  for (size_t i = 0; i < n; ++i) {
    const Frame f = seq.load(i);
    const ros::Time stamp(f.stamp + offset);
    std_msgs::Header h;
    h.stamp = stamp;
    h.seq = static_cast<uint32_t>(i);

    h.frame_id = o.velo_frame;
    bag.write(o.velo_topic, stamp, ros_conv::toPointCloud2(f.scan, h));

    h.frame_id = o.left_frame;
    bag.write(o.left_prefix + "/image_raw", stamp, ros_conv::toImageMsg(f.left, h, "rgb8"));
    bag.write(o.left_prefix + "/camera_info", stamp, ros_conv::toCameraInfo(rig.left, 0.0, h));

    h.frame_id = o.right_frame;
    bag.write(o.right_prefix + "/image_raw", stamp, ros_conv::toImageMsg(f.right, h, "rgb8"));
    bag.write(o.right_prefix + "/camera_info", stamp,
              ros_conv::toCameraInfo(rig.right, Tx_right, h));
    if (progress) progress(i + 1, n);
  }
  bag.close();
}

}  // namespace tescalib
