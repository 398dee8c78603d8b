#include "tescalib/ros/frame_intake.h"

#include <algorithm>
#include <cmath>

#include "tescalib/ros/conversions.h"

namespace tescalib {

namespace {

/// Everything fromCameraInfo reads: P, the size, binning and the region of interest.
bool sameRig(const sensor_msgs::CameraInfo& a, const sensor_msgs::CameraInfo& b) {
  return a.P == b.P && a.width == b.width && a.height == b.height && a.binning_x == b.binning_x &&
         a.binning_y == b.binning_y && a.roi == b.roi;
}

}  // namespace

FrameResult CandidateFrame::addTo(OnlineCalibrator* calibrator, std::string* message,
                                  std::shared_ptr<const Keyframe>* built) const {
  if (previous_scan) calibrator->setPreviousScan(previous_scan, previous_stamp);
  return calibrator->addFrame(frame, lidar_stamp, message, built);
}

std::string ringCountNote(int rings) {
  if (rings < 16)
    return "the LiDAR has " + std::to_string(rings) +
           " rings, fewer than the 16 tescalib is tested with (doc/limitations.md): its mesh has "
           "few faces in view, and solves may say that the window does not constrain every axis";
  if (rings < 64)
    return "the LiDAR has " + std::to_string(rings) +
           " rings: its mesh is sparser than a 64-ring LiDAR's (doc/limitations.md says what that "
           "costs)";
  return "";
}

FrameIntake::FrameIntake(const OnlineSettings& online, double max_stereo_skew)
    : settings_(online), max_stereo_skew_(max_stereo_skew) {}

void FrameIntake::start(const sensor_msgs::CameraInfo& left_info,
                        const sensor_msgs::CameraInfo& right_info) {
  start_left_info_ = left_info;
  start_right_info_ = right_info;
}

bool FrameIntake::isCandidate(double stamp) const {
  // Cheap keyframe pre-selection; time going backwards is passed on (the window resets).
  const double last = last_candidate_stamp_;
  return stamp < last || !settings_.tooClose(stamp, last);
}

bool FrameIntake::cameraInfoChanged(const sensor_msgs::CameraInfo& left_info,
                                    const sensor_msgs::CameraInfo& right_info) const {
  return !sameRig(left_info, start_left_info_) || !sameRig(right_info, start_right_info_);
}

IntakeResult FrameIntake::take(const sensor_msgs::PointCloud2& cloud,
                               const sensor_msgs::Image& left,
                               const sensor_msgs::CameraInfo& left_info,
                               const sensor_msgs::Image& right,
                               const sensor_msgs::CameraInfo& right_info) {
  IntakeResult r;
  const double stamp = left.header.stamp.toSec();
  r.camera_info_changed = cameraInfoChanged(left_info, right_info);
  const bool candidate = isCandidate(stamp);
  // De-skewing registers a keyframe's scan to the set before it: keep every set's scan.
  if (!candidate && !settings_.deskew) return r;
  // The sync pairs each cloud with the nearest left and right images but bounds neither
  // interval: a dropped right frame would pair the left image with the one before.
  const double right_skew = right.header.stamp.toSec() - stamp;
  if (candidate && std::fabs(right_skew) > max_stereo_skew_) {
    r.outcome = IntakeOutcome::kSkewedPair;
    r.reason = "frame rejected: left and right image stamps differ by " +
               std::to_string(right_skew) + " s (sync/max_stereo_skew " +
               std::to_string(max_stereo_skew_) + " s)";
    return r;
  }
  if (!readCloud(cloud, stamp, candidate, &r)) return r;
  countRings(&r);
  std::string error;
  CandidateFrame& c = r.candidate;
  if (!ros_conv::toBgr8Pair(left, right, &c.frame.left, &c.frame.right, &error)) {
    r.outcome = IntakeOutcome::kBadImages;
    r.reason = "image rejected: " + error;
    return r;
  }
  c.frame.stamp = stamp;
  c.lidar_stamp = cloud.header.stamp.toSec();
  last_candidate_stamp_ = stamp;
  r.outcome = IntakeOutcome::kCandidate;
  return r;
}

bool FrameIntake::readCloud(const sensor_msgs::PointCloud2& cloud, double stamp, bool candidate,
                            IntakeResult* r) {
  std::string error;
  CandidateFrame& c = r->candidate;
  bool ring_recovered = false;
  if (!ros_conv::fromPointCloud2(cloud, &c.frame.scan, &error, &ring_recovered)) {
    if (!candidate) return false;
    r->outcome = IntakeOutcome::kBadCloud;
    r->reason = "point cloud rejected: " + error;
    return false;
  }
  r->cloud_converted = true;
  r->time_field = ros_conv::perPointTimeField(cloud);
  if (settings_.deskew) {
    c.previous_scan = last_scan_;
    c.previous_stamp = last_scan_stamp_;
    last_scan_stamp_ = stamp;
    if (!candidate) {  // kept only as the next candidate's previous scan: no copy
      last_scan_ = std::make_shared<const LidarScan>(std::move(c.frame.scan));
      c = CandidateFrame();
      return false;
    }
    last_scan_ = std::make_shared<const LidarScan>(c.frame.scan);
  }
  r->ring_recovered = ring_recovered;
  return true;
}

void FrameIntake::countRings(IntakeResult* r) {
  const LidarScan& scan = r->candidate.frame.scan;
  if (rings_counted_ || scan.empty()) return;
  rings_counted_ = true;  // once: the loop runs over every point
  int rings = 0;
  for (const LidarPoint& p : scan) rings = std::max(rings, p.ring + 1);
  r->rings = rings;
}

}  // namespace tescalib
