// tescalib_eval's report: the summary table over the trials and the JSON of the evaluation
// contract (doc/evaluation.md).
#pragma once

#include <string>
#include <vector>

#include "tescalib/core/solvers/lidar_stereo_solver.h"

#include "eval_args.h"
#include "eval_trial.h"

namespace tescalib::eval {

/// Median of v; NaN when v is empty.
double median(std::vector<double> v);

/// Prints the summary of the trials and, with --json, writes the JSON; false (with the reason on
/// stderr) when the JSON cannot be written.
bool report(const Args& args, const EvalData& d, const LidarStereoSettings& solver_settings,
            const std::vector<Trial>& trials);

}  // namespace tescalib::eval
