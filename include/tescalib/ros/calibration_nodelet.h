// tescalib/CalibrationNodelet: synchronized LiDAR + stereo in, extrinsics with covariance out.
// Thin: callbacks convert and enqueue; a preprocessing thread selects keyframes and builds them;
// a solver thread runs co-calibration on the window. Both threads are joined in the destructor.
#pragma once

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <diagnostic_updater/diagnostic_updater.h>
#include <image_transport/image_transport.h>
#include <image_transport/subscriber_filter.h>
#include <message_filters/subscriber.h>
#include <message_filters/sync_policies/approximate_time.h>
#include <message_filters/sync_policies/exact_time.h>
#include <message_filters/synchronizer.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include <std_srvs/Trigger.h>
#include <tescalib/CalibrationStatus.h>
#include <tescalib/Save.h>

#include "tescalib/core/common/background_worker.h"
#include "tescalib/core/online/online_calibrator.h"
#include "tescalib/core/validation/window_quality.h"
#include "tescalib/ros/frame_intake.h"
#include "tescalib/ros/params.h"

namespace tescalib {

class CalibrationNodelet : public nodelet::Nodelet {
 public:
  ~CalibrationNodelet() override;

 private:
  using Cloud = sensor_msgs::PointCloud2;
  using Image = sensor_msgs::Image;
  using Info = sensor_msgs::CameraInfo;
  using ApproxPolicy =
      message_filters::sync_policies::ApproximateTime<Cloud, Image, Info, Image, Info>;
  using ExactPolicy = message_filters::sync_policies::ExactTime<Cloud, Image, Info, Image, Info>;

  struct PendingFrame {
    CandidateFrame candidate;
    std_msgs::Header header;  ///< the left image's
    ros::WallTime received;   ///< when the synchronized set arrived
  };

  /// Wall-clock durations of one kind (keyframe builds, solves, update latencies), for
  /// /diagnostics and the demo's report: since the start, and over the last kRecent (so that a
  /// drift shows in a long run, where the lifetime figures hardly move).
  struct Durations {
    static constexpr int kRecent = 20;
    int count = 0;
    double sum = 0, max = 0, last = 0;
    std::deque<double> recent;
    void add(double s) {
      ++count, sum += s, last = s;
      if (s > max) max = s;
      recent.push_back(s);
      if (static_cast<int>(recent.size()) > kRecent) recent.pop_front();
    }
    double mean() const { return count ? sum / count : 0.0; }
    double recentMean() const {
      double total = 0;
      for (double v : recent) total += v;
      return recent.empty() ? 0.0 : total / recent.size();
    }
    double recentMax() const {
      double m = 0;
      for (double v : recent) m = std::max(m, v);
      return m;
    }
  };

  void onInit() override;
  /// The private parameters; false (the node inert, saying why) when they are invalid.
  bool loadParams(ros::NodeHandle& pnh);
  /// Both images through ~image_transport; false (the node inert) when it cannot be loaded.
  bool subscribeImages(ros::NodeHandle& nh, ros::NodeHandle& pnh, uint32_t q);
  /// The outputs (estimates, candidates, keyframes for rviz), ~reset and ~save.
  void advertise(ros::NodeHandle& nh, ros::NodeHandle& pnh);
  /// The cloud and camera_info subscriptions and the synchronizer of all five topics.
  void subscribeAndSynchronize(ros::NodeHandle& nh, uint32_t q);
  void syncCallback(const Cloud::ConstPtr& cloud, const Image::ConstPtr& left,
                    const Info::ConstPtr& left_info, const Image::ConstPtr& right,
                    const Info::ConstPtr& right_info);
  bool initCalibrator(const Cloud& cloud, const Info& left_info, const Info& right_info);
  /// Counts a synchronized set for /diagnostics (the first one's arrival, the last one's).
  void countSyncSet(const ros::WallTime& received, double stamp);
  /// Logs a refused set and counts it as a rejected frame.
  void reportRefusal(const IntakeResult& r);
  /// What the clouds' per-point time field (or its absence) means for de-skewing, once.
  void reportTimeField(const std::string& time_field);
  /// The LiDAR's ring count (once) and rings recovered from scan order.
  void reportRings(const IntakeResult& r);
  /// Hands a candidate to the preprocessing thread (at most 2 wait: older ones are dropped).
  void enqueue(PendingFrame pf);
  void preprocessLoop();
  void solveLoop();
  /// `quality`: the estimate's quality scores for ~lidar_to_left (none: its quality_* empty).
  /// Scores and publishes what a solve updated, unless a ~reset cleared it meanwhile; `latency`:
  /// from the oldest keyframe the solve answered to its end, s.
  void publishSolved(const OnlineEstimate& e, double latency);
  void publish(const OnlineEstimate& e, const ros::Time& stamp,
               const WindowQualityScores* quality = nullptr);
  /// With quality/enabled: the quality scores' state for the rig's initial extrinsics.
  void startQuality(const StereoRig& rig);
  /// The estimate's and the initial guess's quality scores on the window's keyframes
  /// (quality/enabled; none when off).
  std::optional<WindowQualityScores> scoreQuality(const OnlineEstimate& e);
  /// The estimate on /tf_static (latched, valid at every time), as robot_state_publisher sends
  /// fixed joints: lookups at now() or at any sensor stamp find it, and it stays after the data
  /// stop or a ~reset (the last published estimate is the best the node has).
  void publishTf(const OnlineEstimate& e, const ros::Time& stamp);
  void startDiagnostics(ros::NodeHandle& nh, ros::NodeHandle& pnh);
  /// Start-up failed (invalid parameters, an image transport that cannot be loaded): log `why`,
  /// keep it on /diagnostics as an error every second, and do nothing else.
  void stayInert(const std::string& why);
  void watchdog(const ros::WallTimerEvent&);
  bool onReset(std_srvs::Trigger::Request& req, std_srvs::Trigger::Response& res);
  bool onSave(Save::Request& req, Save::Response& res);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat);
  /// /diagnostics' level and message: started or not, data coming, estimate, the monitor's
  /// state (ERROR while an extrinsic is changed, WARN while suspect or recalibrating), kept-back
  /// solve.
  void summarize(diagnostic_updater::DiagnosticStatusWrapper& stat,
                 const std::optional<OnlineEstimate>& e, const std::string& problem,
                 double since_last_set, double kept_back_chi2) const;
  /// The keyframe build, solve and update latency durations and the first estimate's figures.
  void addTimings(diagnostic_updater::DiagnosticStatusWrapper& stat);
  /// The published estimate's quality scores against the initial guess, and their cost.
  void addQuality(diagnostic_updater::DiagnosticStatusWrapper& stat);
  /// Keeps `what` as /diagnostics' "last problem" (every rejection and start-up problem: the
  /// log lines are throttled, the diagnostics say what happened last).
  void noteProblem(const std::string& what);

  NodeParams params_;
  /// The synchronized sets' checks and conversion into keyframe candidates (sync callback; its
  /// keyframe pre-selection restarts on ~reset and on a window reset).
  std::unique_ptr<FrameIntake> intake_;
  /// Created once, on the first synchronized set (sync thread), then read by the worker threads,
  /// the diagnostics timer and the services: owned here, published through an atomic pointer.
  std::unique_ptr<OnlineCalibrator> calibrator_owner_;
  std::atomic<OnlineCalibrator*> calibrator_{nullptr};
  OnlineCalibrator* calibrator() const { return calibrator_.load(std::memory_order_acquire); }
  std::string lidar_frame_;

  std::unique_ptr<image_transport::ImageTransport> image_transport_;
  message_filters::Subscriber<Cloud> cloud_sub_;
  image_transport::SubscriberFilter left_sub_, right_sub_;  ///< through ~image_transport
  message_filters::Subscriber<Info> left_info_sub_, right_info_sub_;
  std::unique_ptr<message_filters::Synchronizer<ApproxPolicy>> approx_sync_;
  std::unique_ptr<message_filters::Synchronizer<ExactPolicy>> exact_sync_;
  ros::Publisher lidar_pub_, stereo_pub_, lidar_pose_pub_, stereo_pose_pub_;
  /// Every solve's result, published or not, with why not (OnlineCalibrator::lastSolve).
  ros::Publisher candidate_lidar_pub_, candidate_stereo_pub_;
  void publishEstimateMsgs(const OnlineEstimate& e, const std_msgs::Header& h,
                           const ros::Publisher& lidar, const ros::Publisher& stereo,
                           const WindowQualityScores* quality = nullptr);
  /// Made with the calibrator (quality/enabled): keyframes prepared by quality_prep_, estimates
  /// scored by the solve thread.
  std::unique_ptr<WindowQuality> quality_;
  /// quality_->prepare() of each new keyframe, off the keyframe and solve threads, at a lower
  /// priority than theirs (the nice steps below): they keep up with the sensors first.
  std::unique_ptr<BackgroundWorker<std::shared_ptr<const Keyframe>>> quality_prep_;
  static constexpr int kQualityPreparationNice = 10;
  /// The published estimate's quality scores, for /diagnostics. GUARDED_BY(mutex_).
  std::optional<WindowQualityScores> published_quality_;
  /// Each new keyframe's stereo cloud (left camera frame) and LiDAR mesh, for rviz: computed for
  /// the calibration anyway, published only while someone subscribes.
  ros::Publisher keyframe_cloud_pub_, keyframe_mesh_pub_;
  void publishKeyframe(const Keyframe& kf);
  /// ~status: the calibration monitor's state per extrinsic after every solve (latched).
  ros::Publisher status_pub_;
  void publishStatus();
  ros::ServiceServer reset_srv_, save_srv_;
  ros::WallTimer watchdog_timer_;
  std::unique_ptr<tf2_ros::StaticTransformBroadcaster> tf_pub_;  ///< solve thread only
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;

  std::mutex mutex_;
  /// Held by the solve thread from checking that its estimate is still the calibrator's to the
  /// end of publishing it, and by ~reset around the reset: a solve's estimate is published
  /// entirely before a reset or not at all (never on the latched topics and tf after ~reset has
  /// answered). Taken before mutex_ when both are.
  std::mutex publish_mutex_;
  /// The left images' header stamps of recent keyframes, by the core's double stamp: estimates
  /// and keyframe topics carry their image's exact stamp (a double holds about 0.24 us at today's
  /// epoch, so ros::Time(double) could be 0.1 us off). GUARDED_BY(mutex_).
  std::map<double, ros::Time> keyframe_stamps_;
  /// The exact ros::Time of a keyframe stamp, or the double's when it is not remembered.
  ros::Time rosStamp(double stamp);
  std::condition_variable cv_;
  std::deque<PendingFrame> queue_;  ///< GUARDED_BY(mutex_), at most 2
  std::atomic<bool> running_{false};
  std::atomic<bool> solve_requested_{false};
  std::thread preprocess_thread_, solve_thread_;

  std::atomic<int> sync_sets_{0}, dropped_{0}, rejected_{0}, keyframes_{0};
  /// Messages received per subscribed topic (points, left image, left info, right image, right
  /// info), for the watchdog's messages.
  std::atomic<int> topic_messages_[5] = {};
  ros::WallTime start_wall_;
  /// Names of the subscribed topics whose count is still 0 (empty: all have had messages).
  std::string silentTopics() const;
  /// Set when the parameters are invalid: the node stays inert and says so in /diagnostics.
  std::string param_error_;
  /// Names under the node's namespace it does not read (typos), for /diagnostics.
  std::string unknown_params_;
  std::atomic<double> last_solve_seconds_{0};
  uint64_t last_candidate_id_ = 0;  ///< solve thread only: the last ~candidate/* published
  int init_attempts_ = 0;           ///< sync callback only: initCalibrator calls so far
  std::atomic<bool> solving_{false};
  // Timing, GUARDED_BY(mutex_). The update latency of a keyframe runs from the arrival of its
  // synchronized set to the end of the first solve that includes it; it is only recorded for
  // keyframes that find the window ready (>= window/min_keyframes), so waiting for the window to
  // fill is not counted (that is what `first_estimate_*` reports).
  Durations build_time_, solve_time_, update_latency_;
  Durations quality_time_, quality_prepare_time_;  ///< scoring (solve thread), preparation
  std::vector<ros::WallTime> unsolved_arrivals_;
  ros::WallTime first_set_wall_;  ///< GUARDED_BY(mutex_)
  ros::WallTime last_set_wall_;   ///< GUARDED_BY(mutex_), when the last synchronized set came
  /// Wall seconds without a synchronized set after which /diagnostics warns (data stopped).
  static constexpr double kStaleSeconds = 5.0;
  double first_set_stamp_ = 0;
  int first_estimate_keyframes_ = 0;   ///< keyframes built when the first estimate was published
  double first_estimate_wall_s_ = -1;  ///< wall s from the first synchronized set to it
  double first_estimate_sim_s_ = -1;   ///< same in sensor (bag) time
  std::atomic<int> resets_{0};         ///< ~reset calls (~save's reply says why it has nothing)
  std::string last_problem_;           ///< GUARDED_BY(mutex_)
  std::string last_solve_message_;     ///< GUARDED_BY(mutex_)
};

}  // namespace tescalib
