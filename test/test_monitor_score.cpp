// scoreMonitorRun (monitor_score.h) on synthetic runs whose delays and errors are known.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/eval/monitor_score.h"

namespace tescalib {
namespace {

/// `base` turned by `rot_deg` about z and moved by `trans_m` along x.
Eigen::Isometry3d moved(const Eigen::Isometry3d& base, double rot_deg, double trans_m) {
  Vector6d d = Vector6d::Zero();
  d(2) = rot_deg / kDegPerRad;
  d(3) = trans_m;
  return perturb(base, d);
}

MonitoredEstimate at(double t, bool published, const Eigen::Isometry3d& T, MonitorState m) {
  MonitoredEstimate e;
  e.time = t;
  e.published = published;
  e.T = T;
  e.covariance = Matrix6d::Identity() * 1e-6;
  e.monitor = m;
  return e;
}

ExtrinsicTruth stepAt10() {
  ExtrinsicTruth truth;
  truth.before = moved(Eigen::Isometry3d::Identity(), 1.0, 0.2);
  truth.after = moved(truth.before, 0.5, 0.03);
  truth.step_at = 10;
  return truth;
}

TEST(MonitorScore, DelaysAndErrorsAfterAStep) {
  const ExtrinsicTruth truth = stepAt10();
  using S = MonitorState;
  std::vector<MonitoredEstimate> run;
  for (double t = 1; t < 10; t += 0.5) run.push_back(at(t, true, truth.before, S::kCalibrated));
  run.push_back(at(10.5, false, truth.after, S::kCalibrated));  // not published: not scored
  run.push_back(at(12.0, false, truth.after, S::kSuspect));
  run.push_back(at(12.5, false, truth.after, S::kSuspect));
  run.push_back(at(15.0, false, truth.after, S::kChanged));
  // The first estimate after the step: 0.1 deg off the new truth, closer than the old one.
  run.push_back(at(17.0, true, moved(truth.after, 0.1, 0.0), S::kCalibrated));
  // Farther than the one it replaced (0.3 cm more than a 0.1 deg error in target units).
  run.push_back(at(17.5, true, moved(truth.after, 0.0, 0.03), S::kCalibrated));
  run.push_back(at(18.0, true, moved(truth.after, 0.02, 0.004), S::kCalibrated));
  run.push_back(at(20.0, true, moved(truth.after, 0.2, 0.0), S::kCalibrated));  // after recovery
  const MonitorScore s = scoreMonitorRun(run, truth);
  EXPECT_EQ(s.solves, static_cast<int>(run.size()));
  EXPECT_EQ(s.published, 18 + 4);
  EXPECT_NEAR(s.suspect_share, 2.0 / run.size(), 1e-12);
  EXPECT_EQ(s.changes, 1);
  EXPECT_EQ(s.false_changes, 0);
  EXPECT_DOUBLE_EQ(s.suspect_delay, 2.0);
  EXPECT_DOUBLE_EQ(s.changed_delay, 5.0);
  EXPECT_DOUBLE_EQ(s.first_published_delay, 7.0);
  EXPECT_NEAR(s.first_published_rot_deg, 0.1, 1e-9);
  EXPECT_NEAR(s.first_published_trans_m, 0.0, 1e-9);
  EXPECT_DOUBLE_EQ(s.recovered_delay, 8.0);
  EXPECT_EQ(s.worse_replacements, 1);  // 17.5 s; 20 s comes after the recovery
  EXPECT_NEAR(s.last_rot_deg, 0.2, 1e-9);
  EXPECT_NEAR(s.last_trans_m, 0.0, 1e-9);
}

TEST(MonitorScore, ANewEstimateThatMakesTfWorseAfterTheStepIsCounted) {
  // A published estimate after the step farther from the new truth than the stale one on tf
  // (the negative optimization monitoring has to prevent); never recovered.
  const ExtrinsicTruth truth = stepAt10();
  std::vector<MonitoredEstimate> run = {
      at(9.0, true, truth.before, MonitorState::kCalibrated),
      // Farther than the stale one by less than a tenth of the targets: a tie, not worse.
      at(10.5, true, moved(truth.before, -0.004, 0.0), MonitorState::kCalibrated),
      at(11.0, true, moved(truth.before, -0.5, -0.03), MonitorState::kCalibrated)};
  const MonitorScore s = scoreMonitorRun(run, truth);
  EXPECT_EQ(s.worse_replacements, 1);
  EXPECT_TRUE(std::isnan(s.recovered_delay));
  EXPECT_TRUE(std::isnan(s.suspect_delay));
  EXPECT_TRUE(std::isnan(s.changed_delay));
  EXPECT_DOUBLE_EQ(s.first_published_delay, 0.5);
  EXPECT_NEAR(s.first_published_rot_deg, 0.504, 1e-3);
}

TEST(MonitorScore, AChangeWithoutAStepIsAFalseAlarm) {
  ExtrinsicTruth truth;
  truth.before = truth.after = moved(Eigen::Isometry3d::Identity(), 2.0, 0.1);
  std::vector<MonitoredEstimate> run = {at(1.0, true, truth.before, MonitorState::kCalibrated),
                                        at(2.0, false, truth.before, MonitorState::kSuspect),
                                        at(3.0, false, truth.before, MonitorState::kChanged),
                                        at(4.0, true, truth.before, MonitorState::kCalibrated)};
  const MonitorScore s = scoreMonitorRun(run, truth);
  EXPECT_EQ(s.changes, 1);
  EXPECT_EQ(s.false_changes, 1);
  EXPECT_DOUBLE_EQ(s.suspect_share, 0.25);
  EXPECT_TRUE(std::isnan(s.suspect_delay));  // no step to be late for
  EXPECT_NEAR(s.last_rot_deg, 0.0, 1e-9);
  // A change before the step is a false alarm too.
  ExtrinsicTruth later = stepAt10();
  later.before = later.after = truth.before;
  later.step_at = 20;
  EXPECT_EQ(scoreMonitorRun(run, later).false_changes, 1);
}

TEST(MonitorScore, StateNamesParseBack) {
  for (MonitorState m :
       {MonitorState::kCalibrating, MonitorState::kCalibrated, MonitorState::kSuspect,
        MonitorState::kChanged, MonitorState::kRecalibrating}) {
    MonitorState back = MonitorState::kCalibrating;
    EXPECT_TRUE(parseMonitorState(monitorStateName(m), &back));
    EXPECT_EQ(back, m);
  }
  MonitorState s;
  EXPECT_FALSE(parseMonitorState("broken", &s));
}

}  // namespace
}  // namespace tescalib
