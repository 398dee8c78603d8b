// tescalib_eval's data: the sequences' keyframes, loaded (and de-skewed) once for all the trials.
#pragma once

#include <cstddef>
#include <vector>

#include "tescalib/core/common/types.h"
#include "tescalib/core/solvers/keyframe.h"

#include "eval_args.h"

namespace tescalib::eval {

/// The evaluation's keyframes, loaded (and de-skewed) once; in lidar_stereo mode with their stereo
/// clouds, which do not depend on the LiDAR extrinsic. Meshes depend on the view filter of each
/// trial's initial guess and are rebuilt per trial.
struct EvalData {
  StereoRig rig;  ///< the sequences' calibration (calib.txt): the stereo clouds' rectification
  /// The truth errors are measured against: a generated drive's calib_true.txt (real sensors'
  /// errors moved its right camera off calib.txt's), else `rig`.
  StereoRig truth;
  std::vector<Keyframe> keyframes;
  size_t available = 0;  ///< keyframes in all the sequences (the windows may use fewer)
  size_t window_size = 0, n_windows = 0;
  double stereo_seconds = 0;              ///< wall-clock time of all the stereo clouds
  std::vector<double> kf_stereo_seconds;  ///< each keyframe's share of it
  KeyframeSettings kfs;
  /// The refinement of the clouds co / joint match (co-calibration's own, with the command
  /// line's rounds), and the one the mode's clouds use (printed and written to the JSON).
  DisparityRefinementSettings co_refinement, used_refinement;
};

/// Opens the sequences, cuts them into windows, loads the keyframes; false (with the reason on
/// stderr) when the data cannot be read or does not fill one window.
bool loadData(const Args& args, EvalData* d);

}  // namespace tescalib::eval
