#include "tescalib/ros/calibration_nodelet.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <geometry_msgs/TransformStamped.h>
#include <pluginlib/class_list_macros.hpp>

#include "tescalib/core/common/allocator.h"
#include "tescalib/core/common/geometry.h"
#include "tescalib/core/io/calibration_io.h"
#include "tescalib/core/uncertainty/trust.h"
#include "tescalib/ros/conversions.h"
#include "tescalib/ros/frame_intake.h"
#include "tescalib/ros/initial_rig.h"

namespace tescalib {

CalibrationNodelet::~CalibrationNodelet() {
  // No new callbacks into members about to go: the timer and the inputs stop first.
  watchdog_timer_.stop();
  approx_sync_.reset();
  exact_sync_.reset();
  cloud_sub_.unsubscribe();
  left_sub_.unsubscribe();
  left_info_sub_.unsubscribe();
  right_sub_.unsubscribe();
  right_info_sub_.unsubscribe();
  // A cold co-calibration can run 10-30 s: make it stop within about a second.
  if (calibrator()) calibrator()->cancel();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    running_ = false;
  }
  cv_.notify_all();
  if (preprocess_thread_.joinable()) preprocess_thread_.join();
  if (solve_thread_.joinable()) solve_thread_.join();
  quality_prep_.reset();  // after the thread that feeds it, before what its jobs use
}

void CalibrationNodelet::stayInert(const std::string& why) {
  // The manager and its other nodelets keep running; this one says why on /diagnostics, every
  // second, as an error.
  NODELET_FATAL("tescalib: %s", why.c_str());
  param_error_ = why;
  startDiagnostics(getNodeHandle(), getPrivateNodeHandle());
  watchdog_timer_ =
      getNodeHandle().createWallTimer(ros::WallDuration(1.0), &CalibrationNodelet::watchdog, this);
}

void CalibrationNodelet::onInit() {
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  start_wall_ = ros::WallTime::now();
  if (!loadParams(pnh)) return;
  // Process-wide: the manager's other nodelets share the allocator's settings.
  if (!keepResidentMemoryFlat())
    NODELET_WARN("tescalib: not glibc: the resident memory may grow over a long drive");
  intake_ = std::make_unique<FrameIntake>(params_.online, params_.max_stereo_skew);
  const uint32_t q = 5;
  if (!subscribeImages(nh, pnh, q)) return;
  advertise(nh, pnh);
  subscribeAndSynchronize(nh, q);
  startDiagnostics(nh, pnh);
  // Wall time: diagnostics keep coming when a bag pauses or ends (sim time stands still then).
  watchdog_timer_ = nh.createWallTimer(ros::WallDuration(1.0), &CalibrationNodelet::watchdog, this);
  running_ = true;
  preprocess_thread_ = std::thread(&CalibrationNodelet::preprocessLoop, this);
  solve_thread_ = std::thread(&CalibrationNodelet::solveLoop, this);
  NODELET_INFO(
      "tescalib: waiting for synchronized %s, %s + %s, %s + %s (window %d keyframes >= %.2f s "
      "apart, %s sync)",
      cloud_sub_.getSubscriber().getTopic().c_str(), left_sub_.getTopic().c_str(),
      left_info_sub_.getSubscriber().getTopic().c_str(), right_sub_.getTopic().c_str(),
      right_info_sub_.getSubscriber().getTopic().c_str(), params_.online.window_size,
      params_.online.keyframe_min_dt, params_.approximate_sync ? "approximate" : "exact");
}

bool CalibrationNodelet::loadParams(ros::NodeHandle& pnh) {
  std::string error;
  std::vector<std::string> unknown;
  if (!loadNodeParams(pnh, &params_, &error, &unknown)) {
    while (!error.empty() && (error.back() == ' ' || error.back() == ';')) error.pop_back();
    stayInert("invalid parameters: " + error);
    return false;
  }
  if (!unknown.empty()) {
    std::string names;
    for (const auto& u : unknown) names += (names.empty() ? "" : ", ") + pnh.resolveName(u);
    unknown_params_ = names;
    NODELET_WARN(
        "tescalib: unknown parameter(s) ignored: %s (a typo? config/kitti.yaml and "
        "config/expert.yaml list every parameter)",
        names.c_str());
  }
  return true;
}

bool CalibrationNodelet::subscribeImages(ros::NodeHandle& nh, ros::NodeHandle& pnh, uint32_t q) {
  // The images through image_transport (~image_transport: raw, or compressed where that plugin
  // is installed); a transport that cannot be loaded leaves the node inert, saying why, before
  // anything is advertised. The base topics are resolved here: image_transport's Subscriber
  // does not resolve them, so a remapping of left/image_raw would not reach .../compressed.
  image_transport_ = std::make_unique<image_transport::ImageTransport>(nh);
  const image_transport::TransportHints hints(params_.image_transport, ros::TransportHints(), pnh);
  try {
    left_sub_.subscribe(*image_transport_, nh.resolveName("left/image_raw"), q, hints);
    right_sub_.subscribe(*image_transport_, nh.resolveName("right/image_raw"), q, hints);
  } catch (const std::exception& ex) {
    left_sub_.unsubscribe();  // an inert node receives nothing (left may have subscribed)
    right_sub_.unsubscribe();
    std::string available;
    bool installed = false;
    for (std::string t : image_transport_->getLoadableTransports()) {
      if (t.rfind("image_transport/", 0) == 0) t = t.substr(16);
      installed = installed || t == params_.image_transport;
      available += (available.empty() ? "" : ", ") + t;
    }
    std::string why = ex.what();
    std::replace(why.begin(), why.end(), '\n', ' ');
    stayInert("image_transport \"" + params_.image_transport + "\" cannot be used: " +
              (installed ? why
                         : "installed here: " + available +
                               " (other transports need their plugin package, e.g. "
                               "compressed_image_transport)"));
    return false;
  }
  return true;
}

void CalibrationNodelet::advertise(ros::NodeHandle& nh, ros::NodeHandle& pnh) {
  tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, nh);
  tf_pub_ = std::make_unique<tf2_ros::StaticTransformBroadcaster>();
  lidar_pub_ = pnh.advertise<ExtrinsicEstimate>("lidar_to_left", 1, true);
  stereo_pub_ = pnh.advertise<ExtrinsicEstimate>("left_to_right", 1, true);
  candidate_lidar_pub_ = pnh.advertise<ExtrinsicEstimate>("candidate/lidar_to_left", 1, true);
  candidate_stereo_pub_ = pnh.advertise<ExtrinsicEstimate>("candidate/left_to_right", 1, true);
  lidar_pose_pub_ =
      pnh.advertise<geometry_msgs::PoseWithCovarianceStamped>("lidar_to_left_pose", 1, true);
  stereo_pose_pub_ =
      pnh.advertise<geometry_msgs::PoseWithCovarianceStamped>("left_to_right_pose", 1, true);
  keyframe_cloud_pub_ = pnh.advertise<sensor_msgs::PointCloud2>("keyframe/stereo_cloud", 1, true);
  keyframe_mesh_pub_ = pnh.advertise<visualization_msgs::Marker>("keyframe/lidar_mesh", 1, true);
  status_pub_ = pnh.advertise<CalibrationStatus>("status", 1, true);
  reset_srv_ = pnh.advertiseService("reset", &CalibrationNodelet::onReset, this);
  save_srv_ = pnh.advertiseService("save", &CalibrationNodelet::onSave, this);
}

void CalibrationNodelet::subscribeAndSynchronize(ros::NodeHandle& nh, uint32_t q) {
  cloud_sub_.subscribe(nh, "points", q);
  left_info_sub_.subscribe(nh, "left/camera_info", q);
  right_info_sub_.subscribe(nh, "right/camera_info", q);
  // Every topic's messages are counted for the watchdog, synchronized or not.
  left_sub_.registerCallback(boost::function<void(const Image::ConstPtr&)>(
      [this](const Image::ConstPtr&) { ++topic_messages_[1]; }));
  cloud_sub_.registerCallback(boost::function<void(const Cloud::ConstPtr&)>(
      [this](const Cloud::ConstPtr&) { ++topic_messages_[0]; }));
  left_info_sub_.registerCallback(boost::function<void(const Info::ConstPtr&)>(
      [this](const Info::ConstPtr&) { ++topic_messages_[2]; }));
  right_sub_.registerCallback(boost::function<void(const Image::ConstPtr&)>(
      [this](const Image::ConstPtr&) { ++topic_messages_[3]; }));
  right_info_sub_.registerCallback(boost::function<void(const Info::ConstPtr&)>(
      [this](const Info::ConstPtr&) { ++topic_messages_[4]; }));
  if (params_.approximate_sync) {
    approx_sync_ = std::make_unique<message_filters::Synchronizer<ApproxPolicy>>(
        ApproxPolicy(params_.sync_queue), cloud_sub_, left_sub_, left_info_sub_, right_sub_,
        right_info_sub_);
    approx_sync_->registerCallback(&CalibrationNodelet::syncCallback, this);
  } else {
    exact_sync_ = std::make_unique<message_filters::Synchronizer<ExactPolicy>>(
        ExactPolicy(params_.sync_queue), cloud_sub_, left_sub_, left_info_sub_, right_sub_,
        right_info_sub_);
    exact_sync_->registerCallback(&CalibrationNodelet::syncCallback, this);
  }
}

bool CalibrationNodelet::initCalibrator(const Cloud& cloud, const Info& left_info,
                                        const Info& right_info) {
  InitialRig init;
  std::string error;
  // The first attempt waits up to 0.5 s for tf; later ones (every synchronized set) do not, so
  // that a missing transform does not hold the callback and cost sets meanwhile.
  const double tf_timeout = init_attempts_++ == 0 ? 0.5 : 0.0;
  if (!initialRig(params_, cloud, left_info, right_info, *tf_buffer_, tf_timeout, &init, &error)) {
    NODELET_WARN_THROTTLE(5.0, "tescalib: %s", error.c_str());
    noteProblem(error);
    return false;
  }
  for (const auto& w : init.warnings) NODELET_WARN("tescalib: %s", w.c_str());
  intake_->start(left_info, right_info);
  lidar_frame_ = init.lidar_frame;
  const StereoRig& rig = init.rig;
  calibrator_owner_ = std::make_unique<OnlineCalibrator>(rig, params_.online);
  startQuality(rig);
  // Published last: the worker threads use the calibrator and quality_ once they see it.
  calibrator_.store(calibrator_owner_.get(), std::memory_order_release);
  // tf was needed for the initial guess only: stop listening (a listener's buffer warns of
  // TF_REPEATED_DATA at every loop of a bag, and it reads every /tf message for nothing).
  tf_listener_.reset();
  NODELET_INFO("tescalib: rig %dx%d fx %.1f baseline %.3f m, LiDAR frame '%s'", rig.left.width,
               rig.left.height, rig.left.fx, rig.baseline(), lidar_frame_.c_str());
  return true;
}

void CalibrationNodelet::syncCallback(const Cloud::ConstPtr& cloud, const Image::ConstPtr& left,
                                      const Info::ConstPtr& left_info, const Image::ConstPtr& right,
                                      const Info::ConstPtr& right_info) {
  const ros::WallTime received = ros::WallTime::now();
  countSyncSet(received, left->header.stamp.toSec());
  if (!calibrator() && !initCalibrator(*cloud, *left_info, *right_info)) return;
  // A solve of the old loop's window discards its result now.
  calibrator()->noteStamp(left->header.stamp.toSec());
  IntakeResult r = intake_->take(*cloud, *left, *left_info, *right, *right_info);
  if (r.camera_info_changed) {
    const std::string what =
        "camera_info changed since start-up (P, size, binning or ROI): the node keeps the "
        "intrinsics and "
        "baseline it started with; restart it to use the new ones";
    NODELET_WARN_THROTTLE(30.0, "tescalib: %s", what.c_str());
    noteProblem(what);
  }
  if (r.outcome == IntakeOutcome::kSkewedPair || r.outcome == IntakeOutcome::kBadCloud)
    return reportRefusal(r);
  if (r.cloud_converted) reportTimeField(r.time_field);
  if (r.outcome == IntakeOutcome::kNotCandidate) return;
  reportRings(r);
  if (r.outcome == IntakeOutcome::kBadImages) return reportRefusal(r);
  PendingFrame pf;
  pf.candidate = std::move(r.candidate);
  pf.header = left->header;
  pf.received = received;
  enqueue(std::move(pf));
}

void CalibrationNodelet::countSyncSet(const ros::WallTime& received, double stamp) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (sync_sets_++ == 0) {
    first_set_wall_ = received;
    first_set_stamp_ = stamp;
    last_problem_.clear();  // the watchdog's "no messages on ..." is over
  }
  last_set_wall_ = received;
}

void CalibrationNodelet::reportRefusal(const IntakeResult& r) {
  ++rejected_;
  // One throttle per kind of refusal: a frequent one does not hide the others.
  if (r.outcome == IntakeOutcome::kSkewedPair)
    NODELET_WARN_THROTTLE(5.0, "tescalib: %s", r.reason.c_str());
  else if (r.outcome == IntakeOutcome::kBadCloud)
    NODELET_WARN_THROTTLE(5.0, "tescalib: %s", r.reason.c_str());
  else
    NODELET_WARN_THROTTLE(5.0, "tescalib: %s", r.reason.c_str());
  noteProblem(r.reason);
}

void CalibrationNodelet::reportTimeField(const std::string& time_field) {
  if (params_.online.deskew) {
    if (!time_field.empty())
      NODELET_INFO_ONCE("tescalib: de-skewing with the clouds' per-point time field '%s'",
                        time_field.c_str());
    else if (params_.online.sweep.by_azimuth)
      NODELET_WARN_ONCE(
          "tescalib: the clouds have no per-point time field: de-skewed by azimuth, which is "
          "right only for a LiDAR phase-locked to the cameras that faces "
          "deskew/reference_azimuth_deg (%.1f deg, LiDAR frame) at every image stamp, as KITTI's. "
          "Otherwise set deskew/by_azimuth false, or deskew:=false when the driver compensates "
          "the motion",
          params_.online.sweep.reference_azimuth_rad * kDegPerRad);
    else
      NODELET_WARN_ONCE(
          "tescalib: the clouds have no per-point time field: not de-skewed (deskew/by_azimuth "
          "true times their points by azimuth, for a LiDAR phase-locked to the cameras such as "
          "KITTI's)");
  } else if (!time_field.empty()) {
    NODELET_WARN_ONCE(
        "tescalib: the point cloud has a per-point time field ('%s'): a raw sweep, whose "
        "points the vehicle's motion skews (14 cm at the image edges at 12 m/s). Set "
        "deskew/enabled (launch argument deskew:=true) unless the driver compensated them.",
        time_field.c_str());
  }
}

void CalibrationNodelet::reportRings(const IntakeResult& r) {
  if (r.rings >= 0 && r.rings < 16)
    NODELET_WARN_ONCE("tescalib: %s", ringCountNote(r.rings).c_str());
  else if (r.rings >= 0 && r.rings < 64)
    NODELET_INFO_ONCE("tescalib: %s", ringCountNote(r.rings).c_str());
  if (r.ring_recovered)
    NODELET_WARN_THROTTLE(30.0,
                          "tescalib: point cloud has no 'ring' field; rings recovered from "
                          "scan order (KITTI-style clouds)");
}

void CalibrationNodelet::enqueue(PendingFrame pf) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    queue_.push_back(std::move(pf));
    while (queue_.size() > 2) {
      queue_.pop_front();
      ++dropped_;
      NODELET_WARN_THROTTLE(5.0,
                            "tescalib: preprocessing cannot keep up: dropped a keyframe candidate");
    }
  }
  cv_.notify_all();
}

void CalibrationNodelet::preprocessLoop() {
  while (running_) {
    PendingFrame pf;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      cv_.wait_for(lock, std::chrono::milliseconds(200),
                   [this] { return !queue_.empty() || !running_; });
      if (!running_) return;
      if (queue_.empty()) continue;
      pf = std::move(queue_.front());
      queue_.pop_front();
    }
    std::string msg;
    const ros::WallTime t0 = ros::WallTime::now();
    std::shared_ptr<const Keyframe> kf;
    const FrameResult r = pf.candidate.addTo(calibrator(), &msg, &kf);
    if (r == FrameResult::kKeyframe) {
      const double build_s = (ros::WallTime::now() - t0).toSec();
      {
        std::lock_guard<std::mutex> lock(mutex_);
        keyframe_stamps_[pf.candidate.frame.stamp] = pf.header.stamp;
        // More than any window holds; older ones (and a looped bag's) are no longer asked for.
        while (keyframe_stamps_.size() > 256) keyframe_stamps_.erase(keyframe_stamps_.begin());
      }
      if (kf) publishKeyframe(*kf);
      const size_t fill = calibrator()->windowFill();
      {
        std::lock_guard<std::mutex> lock(mutex_);
        build_time_.add(build_s);
        if (static_cast<int>(fill) >= params_.online.minKeyframes())
          unsolved_arrivals_.push_back(pf.received);
      }
      NODELET_DEBUG("tescalib: keyframe %d built in %.3f s (window %zu)", keyframes_.load() + 1,
                    build_s, fill);
      if (!msg.empty()) {
        NODELET_WARN("tescalib: %s", msg.c_str());
        noteProblem(msg);
      }
      const int built = ++keyframes_;
      {
        // Under the lock the solve thread waits with: the wake-up cannot fall between its check
        // of the flag and its wait.
        std::lock_guard<std::mutex> lock(mutex_);
        solve_requested_ = true;
      }
      cv_.notify_all();
      // What the quality scores need of the keyframe, prepared on the cores the keyframes and
      // the solves leave idle, so that the published estimate waits only for its own scores.
      if (kf && quality_prep_) quality_prep_->push(kf);
      returnFreeMemoryAfterKeyframe(built);  // once the solve is on its way
    } else if (r == FrameResult::kReset) {
      NODELET_WARN("tescalib: %s", msg.c_str());
      noteProblem(msg);
      intake_->restartSelection(pf.candidate.frame.stamp);
      std::lock_guard<std::mutex> lock(mutex_);
      unsolved_arrivals_.clear();
    } else if (r == FrameResult::kRejected) {
      ++rejected_;
      NODELET_WARN_THROTTLE(5.0, "tescalib: frame rejected: %s", msg.c_str());
      noteProblem("frame rejected: " + msg);
    }
  }
}

void CalibrationNodelet::solveLoop() {
  while (running_) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      cv_.wait_for(lock, std::chrono::milliseconds(200),
                   [this] { return solve_requested_ || !running_; });
    }
    if (!running_) return;
    // A request that finds the window not ready yet is consumed: the next keyframe renews it.
    if (!solve_requested_.exchange(false) || !calibrator() || !calibrator()->readyToSolve())
      continue;
    std::vector<ros::WallTime> arrivals;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      arrivals.swap(unsolved_arrivals_);
    }
    std::string msg;
    solving_ = true;
    const auto t0 = ros::WallTime::now();
    OnlineEstimate published;
    const bool updated = calibrator()->solve(&msg, &published);
    const auto t1 = ros::WallTime::now();
    solving_ = false;
    last_solve_seconds_ = (t1 - t0).toSec();
    double latency = 0;  // of the oldest keyframe this solve answered
    // What this solve published (a ~reset right after it must not leave us without it).
    const std::optional<OnlineEstimate> e =
        updated ? std::optional<OnlineEstimate>(published) : std::nullopt;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      last_solve_message_ = updated ? "updated" : msg;
      solve_time_.add(last_solve_seconds_);
      for (const auto& a : arrivals) {
        update_latency_.add((t1 - a).toSec());
        latency = std::max(latency, (t1 - a).toSec());
      }
      if (updated && first_estimate_keyframes_ == 0) {
        first_estimate_keyframes_ = keyframes_;
        first_estimate_wall_s_ = (t1 - first_set_wall_).toSec();
        first_estimate_sim_s_ = e->stamp - first_set_stamp_;
      }
    }
    // Every solve's result on ~candidate/*, published or not (status: why not).
    const auto c = calibrator()->lastSolve();
    if (c && c->solve_id != last_candidate_id_) {  // not again after a discarded solve
      last_candidate_id_ = c->solve_id;
      std_msgs::Header h;
      h.stamp = rosStamp(c->stamp);
      publishEstimateMsgs(*c, h, candidate_lidar_pub_, candidate_stereo_pub_);
      publishStatus();
    }
    if (updated)
      publishSolved(*e, latency);
    else if (c && c->held_between_windows)
      NODELET_DEBUG("tescalib: %s", msg.c_str());
    else
      NODELET_WARN_THROTTLE(5.0, "tescalib: %s", msg.c_str());
  }
}

/// Scores and publishes what a solve updated, unless a ~reset cleared it meanwhile.
void CalibrationNodelet::publishSolved(const OnlineEstimate& e, double latency) {
  // Before the lock: a ~reset meanwhile waits for no scoring.
  const std::optional<WindowQualityScores> quality = scoreQuality(e);
  std::lock_guard<std::mutex> publishing(publish_mutex_);
  const auto current = calibrator()->estimate();
  if (!current || current->solve_id != e.solve_id) {
    NODELET_INFO(
        "tescalib: a ~reset cleared the estimate from %d keyframes before it was "
        "published: not published",
        e.keyframes_used);
    return;
  }
  publish(e, rosStamp(e.stamp), quality ? &*quality : nullptr);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    published_quality_ = quality;
  }
  std::string kind = e.stereo_estimated ? "LiDAR-stereo, T_right_left kept"
                                        : "LiDAR-stereo, T_right_left not estimated";
  if (e.co_rounds > 0 && params_.online.joint)
    kind = "joint co-calibration, " + std::to_string(e.co_rounds) + " outer iteration(s)";
  else if (e.co_rounds > 0)
    kind = "co-calibration, " + std::to_string(e.co_rounds) + " round(s)";
  if (e.windows_averaged > 1)
    kind += ", the mean of " + std::to_string(e.windows_averaged) + " windows";
  NODELET_INFO(
      "tescalib: new estimate from %d keyframes in %.2f s (keyframe to estimate %.2f s; %s)",
      e.keyframes_used, last_solve_seconds_.load(), latency, kind.c_str());
  if (quality)
    NODELET_INFO("tescalib: quality on %d keyframes (%.3f s): %s", quality->keyframes,
                 quality->seconds, quality->summary().c_str());
}

void CalibrationNodelet::publish(const OnlineEstimate& e, const ros::Time& stamp,
                                 const WindowQualityScores* quality) {
  std_msgs::Header h;
  h.stamp = stamp;
  publishEstimateMsgs(e, h, lidar_pub_, stereo_pub_, quality);
  h.frame_id = params_.left_frame;
  lidar_pose_pub_.publish(ros_conv::toPoseMsg(h, e.T_cam_lidar, e.cov_lidar, e.cov_lidar_known));
  h.frame_id = params_.right_frame;
  stereo_pose_pub_.publish(ros_conv::toPoseMsg(h, e.T_right_left, e.cov_stereo,
                                               e.stereo_estimated && e.cov_stereo_known));
  publishTf(e, stamp);
}

void CalibrationNodelet::publishEstimateMsgs(const OnlineEstimate& e, const std_msgs::Header& h,
                                             const ros::Publisher& lidar,
                                             const ros::Publisher& stereo,
                                             const WindowQualityScores* quality) {
  ExtrinsicEstimate m = ros_conv::toEstimateMsg(
      h, params_.left_frame, lidar_frame_, e.T_cam_lidar, e.cov_lidar, e.observable_lidar,
      e.converged, e.keyframes_used, e.cost_lidar, e.iterations_lidar, e.message, true,
      e.weakest_lidar, e.cov_lidar_known);
  if (quality) ros_conv::setQuality(*quality, &m);
  m.windows_averaged = static_cast<uint32_t>(e.windows_averaged);
  lidar.publish(m);
  ExtrinsicEstimate s = ros_conv::toEstimateMsg(
      h, params_.right_frame, params_.left_frame, e.T_right_left, e.cov_stereo, e.observable_stereo,
      e.converged, e.keyframes_used, e.cost_stereo, e.iterations_stereo, e.message,
      e.stereo_estimated, e.weakest_stereo, e.cov_stereo_known);
  s.windows_averaged = static_cast<uint32_t>(e.windows_averaged);
  stereo.publish(s);
}

ros::Time CalibrationNodelet::rosStamp(double stamp) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = keyframe_stamps_.find(stamp);
  return it != keyframe_stamps_.end() ? it->second : ros::Time(stamp);
}

void CalibrationNodelet::publishKeyframe(const Keyframe& kf) {
  std_msgs::Header h;
  h.stamp = rosStamp(kf.stamp);
  if (keyframe_cloud_pub_.getNumSubscribers() > 0) {
    h.frame_id = params_.left_frame;  // shown once the first estimate puts that frame on tf
    keyframe_cloud_pub_.publish(ros_conv::toPointCloud2(kf.stereo, h));
  }
  if (keyframe_mesh_pub_.getNumSubscribers() > 0) {
    h.frame_id = lidar_frame_;
    keyframe_mesh_pub_.publish(ros_conv::toMeshMarker(kf.mesh, h));
  }
}

void CalibrationNodelet::publishTf(const OnlineEstimate& e, const ros::Time& stamp) {
  geometry_msgs::TransformStamped a, b;
  a.header.stamp = b.header.stamp = stamp;
  // tf: the transform maps child points into the parent frame.
  a.header.frame_id = lidar_frame_;
  a.child_frame_id = params_.left_frame;
  a.transform = ros_conv::toTransformMsg(e.T_cam_lidar.inverse());
  b.header.frame_id = params_.left_frame;
  b.child_frame_id = params_.right_frame;
  b.transform = ros_conv::toTransformMsg(e.T_right_left.inverse());
  tf_pub_->sendTransform(std::vector<geometry_msgs::TransformStamped>{a, b});
}

bool CalibrationNodelet::onReset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  std::lock_guard<std::mutex> publishing(publish_mutex_);  // no solve publishes across it
  if (calibrator()) calibrator()->reset();
  {
    // Sets received before the reset are not the fresh window's either.
    std::lock_guard<std::mutex> lock(mutex_);
    queue_.clear();
    unsolved_arrivals_.clear();
    last_solve_message_.clear();  // it was the cleared window's (~save and /diagnostics show it)
  }
  intake_->restartSelection();
  ++resets_;
  res.success = true;
  res.message = "window cleared, back to the initial extrinsics";
  NODELET_INFO("tescalib: reset");
  return true;
}

bool CalibrationNodelet::onSave(Save::Request& req, Save::Response& res) {
  const std::string base = req.path.empty() ? params_.save_path : req.path;
  const auto e = calibrator() ? calibrator()->estimate() : std::nullopt;
  if (!e) {
    res.success = false;
    res.message = resets_ > 0
                      ? "no converged estimate since the last ~reset (the latched topics and tf "
                        "still hold the one before it, which the reset discarded)"
                      : "no converged estimate yet";
    // Why not: the last solve's reason (~candidate/* has its result).
    std::lock_guard<std::mutex> lock(mutex_);
    if (!last_solve_message_.empty()) res.message += "; the last solve: " + last_solve_message_;
    return true;
  }
  CalibrationFrames frames;
  frames.lidar = lidar_frame_;
  frames.left = params_.left_frame;
  frames.right = params_.right_frame;
  // Relative paths are relative to the node's working directory, ROS_HOME (~/.ros) under
  // roslaunch: the reply names the files with their absolute paths.
  std::error_code ec;
  const std::filesystem::path absolute = std::filesystem::absolute(base, ec);
  res.success = writeCalibrationFiles(ec ? base : absolute.string(), calibrator()->rig(), *e,
                                      frames, &res.message);
  return true;
}

}  // namespace tescalib

PLUGINLIB_EXPORT_CLASS(tescalib::CalibrationNodelet, nodelet::Nodelet)
