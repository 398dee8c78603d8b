// Parameter loading for the nodelets: one loader, grouped like the core settings structs, that
// validates every value and says clearly what is wrong.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <ros/node_handle.h>

#include "tescalib/core/online/online_calibrator.h"

namespace tescalib {

struct NodeParams {
  /// User-provided (every default comes from the members): with an implicit one GCC 12 reports
  /// the vectors of a temporary NodeParams{} as maybe uninitialized.
  NodeParams() {}
  OnlineSettings online;
  bool approximate_sync = true;  ///< message_filters ApproximateTime (else ExactTime)
  /// s; left and right image stamps further apart are not one stereo pair (a dropped frame paired
  /// with its neighbour): a pair's cameras fire together, and 20 ms at 12 m/s is 24 cm of motion.
  double max_stereo_skew = 0.02;
  int sync_queue = 10;
  /// image_transport plugin the images arrive through ("raw"; "compressed" or "theora" where
  /// those plugins are installed): the standard `~image_transport` parameter.
  std::string image_transport = "raw";
  std::string lidar_frame;                     ///< empty: the point cloud's header frame
  std::string left_frame = "tescalib_left";    ///< published (child of the LiDAR frame)
  std::string right_frame = "tescalib_right";  ///< published (child of left_frame)
  /// Initial T_cam_lidar as [x y z qx qy qz qw] (LiDAR -> left camera); empty: from tf.
  std::vector<double> initial_T_cam_lidar;
  /// Initial T_right_left as [x y z qx qy qz qw]; empty: from the right camera_info (P[3]).
  std::vector<double> initial_T_right_left;
  /// With an empty initial_T_cam_lidar: the initial extrinsic is tf's transform from the cloud's
  /// frame to this one; empty: the left image's frame_id.
  std::string initial_tf_camera_frame;
  double initial_perturb_rot_deg = 0;  ///< demo/testing: perturb the initial guesses by this
  double initial_perturb_trans_m = 0;
  int initial_perturb_seed = 1;
  std::string save_path = "tescalib_calibration";
  /// lidar_stereo/halves_start: where the split-window check's halves start (recheck, estimate or
  /// initial; halvesStartFromName), applied to online.co.lidar.halves_start by loadNodeParams.
  std::string halves_start = "recheck";
  /// Score each published estimate and the initial guess on its keyframes with the validation
  /// criteria (WindowQuality: about 0.05 s per keyframe in the keyframe thread, 0.02 s per
  /// estimate in the solve thread, 0.07 s per co-calibrated one, on 2 cores) for
  /// ~lidar_to_left's quality_* and /diagnostics.
  bool quality_enabled = true;
};

/// Loads and validates the private parameters. Returns false and a message naming the
/// parameter on any invalid value. `unknown`, when given, receives the names under `pnh` that
/// are not parameters of the node (typos: they would otherwise be ignored without a word).
bool loadNodeParams(const ros::NodeHandle& pnh, NodeParams* params, std::string* error,
                    std::vector<std::string>* unknown = nullptr);

/// Every parameter the node reads, by its name under the private namespace ("window/size"), with
/// its value in `p` as text: what config/kitti.yaml is checked against.
std::map<std::string, std::string> nodeParamValues(NodeParams p);

/// Validates a loaded parameter set (also used by the test of config/*.yaml).
bool validateNodeParams(const NodeParams& p, std::string* error);

}  // namespace tescalib
