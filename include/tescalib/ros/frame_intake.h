// One synchronized sensor set (point cloud, left and right image, their camera_info) -> a core
// Frame for OnlineCalibrator::addFrame, or the reason it is refused. The nodelet's sync callback
// and tescalib_calibrate --bag both take their sets through it, so that the two run the same
// checks: keyframe pre-selection, the left/right image skew, the cloud and image conversions,
// the scan kept for de-skewing the next candidate, the camera_info seen at start-up and the
// LiDAR's ring count.
#pragma once

#include <atomic>
#include <memory>
#include <string>

#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>

#include "tescalib/core/online/online_calibrator.h"

namespace tescalib {

/// What FrameIntake::take made of a set.
enum class IntakeOutcome {
  kCandidate,     ///< a keyframe candidate, converted: IntakeResult::candidate is ready
  kNotCandidate,  ///< too soon after the last candidate (or its cloud unusable): skipped silently
  kSkewedPair,    ///< refused: the left and right image stamps differ by more than the limit
  kBadCloud,      ///< refused: the candidate's point cloud cannot be converted
  kBadImages,     ///< refused: an image of the candidate cannot be converted
};

/// A keyframe candidate for OnlineCalibrator, with de-skewing the scan of the set before it.
struct CandidateFrame {
  Frame frame;  ///< stamped with the left image's stamp
  double lidar_stamp = 0;
  /// With de-skewing: the previous set's scan, which the candidate's motion is registered to
  /// (null for the first set).
  std::shared_ptr<const LidarScan> previous_scan;
  double previous_stamp = 0;

  /// setPreviousScan (when there is a previous scan), then addFrame.
  FrameResult addTo(OnlineCalibrator* calibrator, std::string* message,
                    std::shared_ptr<const Keyframe>* built = nullptr) const;
};

struct IntakeResult {
  IntakeOutcome outcome = IntakeOutcome::kNotCandidate;
  /// For a refusal, what the caller logs: "frame rejected: left and right image stamps differ
  /// ...", "point cloud rejected: ...", "image rejected: ...".
  std::string reason;
  CandidateFrame candidate;  ///< kCandidate (and kBadImages: its scan and stamps)

  // Observations the caller reports in its own words.
  /// A camera_info differs from the start-up one in what the rig was made from (P, size,
  /// binning, ROI): the intrinsics and baseline stay those of the start.
  bool camera_info_changed = false;
  bool cloud_converted = false;  ///< the cloud was converted (time_field is then known)
  std::string time_field;        ///< the cloud's per-point time field, "" when it has none
  /// For a candidate: its cloud had no ring field, the rings were recovered from scan order.
  bool ring_recovered = false;
  /// The LiDAR's ring count, counted once, on the first candidate with points (-1 otherwise).
  int rings = -1;

  bool refused() const {
    return outcome == IntakeOutcome::kSkewedPair || outcome == IntakeOutcome::kBadCloud ||
           outcome == IntakeOutcome::kBadImages;
  }
};

/// What the ring count means for the accuracy to expect (doc/limitations.md): "" for 64 rings
/// or more. Below 16 rings it is a warning, below 64 a note.
std::string ringCountNote(int rings);

/// Turns synchronized sets into keyframe candidates, keeping the state the checks need between
/// sets. take() is called from one thread (the sync callback); restartSelection() may be called
/// from any.
class FrameIntake {
 public:
  /// `online`: the calibrator's settings (keyframe spacing, de-skewing); `max_stereo_skew`: s
  /// between the left and right image stamps of one pair (the node's sync/max_stereo_skew).
  FrameIntake(const OnlineSettings& online, double max_stereo_skew);

  /// The camera_infos the rig was made from: later sets' are compared with them.
  void start(const sensor_msgs::CameraInfo& left_info, const sensor_msgs::CameraInfo& right_info);

  IntakeResult take(const sensor_msgs::PointCloud2& cloud, const sensor_msgs::Image& left,
                    const sensor_msgs::CameraInfo& left_info, const sensor_msgs::Image& right,
                    const sensor_msgs::CameraInfo& right_info);

  /// The next set is judged against `stamp` as the last candidate's (the default: any set is a
  /// candidate), after a reset of the window.
  void restartSelection(double stamp = -1e300) { last_candidate_stamp_ = stamp; }

 private:
  bool isCandidate(double stamp) const;
  bool cameraInfoChanged(const sensor_msgs::CameraInfo& left_info,
                         const sensor_msgs::CameraInfo& right_info) const;
  /// Converts the cloud and, with de-skewing, keeps its scan for the next candidate. False when
  /// the set ends here (its cloud refused or, not a candidate, only kept).
  bool readCloud(const sensor_msgs::PointCloud2& cloud, double stamp, bool candidate,
                 IntakeResult* r);
  void countRings(IntakeResult* r);

  OnlineSettings settings_;
  double max_stereo_skew_;
  sensor_msgs::CameraInfo start_left_info_, start_right_info_;
  std::atomic<double> last_candidate_stamp_{-1e300};
  /// With de-skewing: the last set's scan and its stamp.
  std::shared_ptr<const LidarScan> last_scan_;
  double last_scan_stamp_ = -1e300;
  bool rings_counted_ = false;
};

}  // namespace tescalib
