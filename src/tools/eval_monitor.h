// tescalib_eval --score-estimates FILE: a tescalib_calibrate --json run on a generated drive scored
// against the truth of each estimate's moment (monitor_score.h), printed and written to --json.
#pragma once

#include "eval_args.h"

namespace tescalib::eval {

/// Scores args.score_estimates against the drive in args.sequences (one folder); false with the
/// reason on stderr when the estimates or the truth cannot be read.
bool scoreEstimates(const Args& args);

}  // namespace tescalib::eval
