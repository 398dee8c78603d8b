#include "tescalib/ros/bag_sets.h"

#include <cmath>
#include <deque>

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <tf2/exceptions.h>
#include <tf2_msgs/TFMessage.h>

#include "tescalib/core/common/error.h"
#include "tescalib/ros/compressed_image.h"
#include "tescalib/ros/conversions.h"

namespace tescalib {

namespace {

template <class Msg>
double stampOf(const Msg& m) {
  return m->header.stamp.toSec();
}

/// The buffered image nearest to `t`, or null.
sensor_msgs::Image::ConstPtr nearest(const std::deque<sensor_msgs::Image::ConstPtr>& images,
                                     double t) {
  sensor_msgs::Image::ConstPtr best;
  for (const auto& im : images)
    if (!best || std::fabs(stampOf(im) - t) < std::fabs(stampOf(best) - t)) best = im;
  return best;
}

void openBag(rosbag::Bag* bag, const std::string& path) {
  try {
    bag->open(path, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    throw DataError(path + ": cannot open the bag: " + e.what());
  }
}

}  // namespace

BagCounts readBagSets(const std::string& path, const BagTopics& topics,
                      const std::function<void(const BagSet&)>& on_set) {
  rosbag::Bag bag;
  openBag(&bag, path);
  rosbag::View view(
      bag, rosbag::TopicQuery(std::vector<std::string>{topics.points, topics.left, topics.right,
                                                       topics.left_info, topics.right_info}));
  BagCounts n;
  std::deque<sensor_msgs::PointCloud2::ConstPtr> clouds;
  std::deque<sensor_msgs::Image::ConstPtr> lefts, rights;
  sensor_msgs::CameraInfo::ConstPtr left_info, right_info;
  // Decides the oldest clouds whose images can no longer come closer: both image streams have
  // passed their stamp by max_skew (or the bag ended, or too many clouds wait: an image topic
  // missing from the bag must not keep every cloud in memory).
  auto decide = [&](bool end) {
    while (!clouds.empty()) {
      const double t = stampOf(clouds.front());
      const bool images_passed = !lefts.empty() && stampOf(lefts.back()) > t + topics.max_skew &&
                                 !rights.empty() && stampOf(rights.back()) > t + topics.max_skew;
      if (!end && !images_passed && clouds.size() < 20) break;
      const auto l = nearest(lefts, t), r = nearest(rights, t);
      if (l && r && left_info && right_info && std::fabs(stampOf(l) - t) <= topics.max_skew &&
          std::fabs(stampOf(r) - t) <= topics.max_skew) {
        ++n.sets;
        on_set(BagSet{clouds.front(), l, r, left_info, right_info});
      } else {
        ++n.unmatched_clouds;
      }
      clouds.pop_front();
      // Later clouds are newer: images more than max_skew older than this one are of no use.
      for (auto* q : {&lefts, &rights})
        while (!q->empty() && stampOf(q->front()) < t - topics.max_skew) q->pop_front();
    }
  };
  for (const rosbag::MessageInstance& m : view) {
    const std::string& topic = m.getTopic();
    if (topic == topics.points) {
      if (const auto c = m.instantiate<sensor_msgs::PointCloud2>()) clouds.push_back(c), ++n.clouds;
    } else if (topic == topics.left || topic == topics.right) {
      sensor_msgs::Image::ConstPtr im = m.instantiate<sensor_msgs::Image>();
      if (const auto c = im ? nullptr : m.instantiate<sensor_msgs::CompressedImage>()) {
        im = decodeCompressedImage(*c);
        if (!im) ++n.undecodable_images;
      }
      if (im) {
        (topic == topics.left ? lefts : rights).push_back(im);
        ++(topic == topics.left ? n.left : n.right);
      }
    } else if (topic == topics.left_info) {
      if (const auto i = m.instantiate<sensor_msgs::CameraInfo>()) left_info = i;
    } else if (topic == topics.right_info) {
      if (const auto i = m.instantiate<sensor_msgs::CameraInfo>()) right_info = i;
    }
    decide(false);
  }
  decide(true);
  if (n.clouds == 0) throw DataError(path + ": no messages on " + topics.points);
  return n;
}

void readBagStaticTf(const std::string& path, tf2::BufferCore* buffer) {
  rosbag::Bag bag;
  openBag(&bag, path);
  for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery("/tf_static")))
    if (const auto tf = m.instantiate<tf2_msgs::TFMessage>())
      for (const auto& t : tf->transforms) buffer->setTransform(t, "bag", true);
}

Eigen::Isometry3d bagLidarExtrinsic(const std::string& path, const tf2::BufferCore& tf,
                                    const BagSet& set, const std::string& hint) {
  const std::string cam = set.left_info->header.frame_id.empty() ? set.left->header.frame_id
                                                                 : set.left_info->header.frame_id;
  try {
    return ros_conv::fromTransformMsg(
        tf.lookupTransform(cam, set.cloud->header.frame_id, ros::Time(0)).transform);
  } catch (const tf2::TransformException& e) {
    throw DataError(path + ": no LiDAR extrinsic on /tf_static (" + cam + " <- " +
                    set.cloud->header.frame_id + ": " + e.what() + ")" + hint);
  }
}

}  // namespace tescalib
