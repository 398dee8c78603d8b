// tescalib_eval: runs the calibration on KITTI-layout sequences from perturbed initial guesses
// and measures it against the ground truth (contract: doc/evaluation.md).
#include <iostream>
#include <vector>

#include "eval_args.h"
#include "eval_monitor.h"
#include "eval_report.h"
#include "eval_trial.h"

using namespace tescalib::eval;

int main(int argc, char** argv) {
  Args args;
  if (!parse(argc, argv, &args)) {  // the reason is on stderr; the usage would scroll it away
    std::cerr << "tescalib_eval: --help lists the options\n";
    return 2;
  }
  if (!args.score_estimates.empty()) return scoreEstimates(args) ? 0 : 1;
  EvalData data;
  if (!loadData(args, &data)) return 1;
  const tescalib::LidarStereoSettings solver_settings = lidarSettings(args, data.kfs);
  std::vector<Trial> trials;
  printTrialHeader();
  for (int t = args.first_trial; t < args.first_trial + args.trials; ++t) {
    trials.push_back(runTrial(args, t, solver_settings, &data));
    printTrial(args, t, trials.back());
  }
  return report(args, data, solver_settings, trials) ? 0 : 1;
}
