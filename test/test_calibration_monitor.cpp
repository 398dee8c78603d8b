// The calibration monitor on synthetic estimate sequences (no images): its state machine, the
// CUSUM, no false alarm under noise within the covariances, and a step detected.
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/online/calibration_monitor.h"
#include "tescalib/core/online/keyframe_window.h"
#include "tescalib/core/online/publish_policy.h"
#include "tescalib/core/online/window_solve.h"
#include "tescalib/core/uncertainty/trust.h"

using namespace tescalib;

namespace {

/// Keyframe stamps of a 10-keyframe window (0.5 s apart) whose newest keyframe is `newest`.
std::vector<double> window(double newest) {
  std::vector<double> s;
  for (int i = 9; i >= 0; --i) s.push_back(newest - 0.5 * i);
  return s;
}

/// A window estimate's covariance like a generated urban drive's (0.02 deg, 5 mm per axis).
Matrix6d windowCovariance() {
  Vector6d sigma;
  sigma << 0.02, 0.02, 0.02, 0, 0, 0;
  sigma.head<3>() /= kDegPerRad;
  sigma.tail<3>().setConstant(0.005);
  return sigma.cwiseAbs2().asDiagonal();
}

/// A window's estimate drawn from the window covariance around the truth moved by `offset`.
Eigen::Isometry3d drawEstimate(const Vector6d& offset, std::mt19937_64& rng) {
  const Matrix6d P = windowCovariance();
  std::normal_distribution<double> n(0, 1);
  Vector6d a;
  for (int i = 0; i < 6; ++i) a(i) = std::sqrt(P(i, i)) * n(rng);
  return perturb(Eigen::Isometry3d::Identity(), offset + a);
}

/// With kUnit covariances on both sides: an estimate at `chi2` from the identity reference.
const Matrix6d kUnit = Matrix6d::Identity() * 1e-4;
Eigen::Isometry3d atChi2(double chi2) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation().x() = std::sqrt(2e-4 * chi2);
  return T;
}
const Eigen::Isometry3d kI = Eigen::Isometry3d::Identity();

/// A keyframe stamped `stamp`, with nothing else.
std::shared_ptr<Keyframe> keyframe(double stamp) {
  auto k = std::make_shared<Keyframe>();
  k->stamp = stamp;
  return k;
}

/// Information of a town keyframe (every direction) and of a highway one (nothing along z).
const Matrix6d kTown = Matrix6d::Identity() * 1e6;
const Matrix6d kHighway = (Vector6d() << 1e6, 1e6, 1e6, 1e6, 1e6, 1.0).finished().asDiagonal();

/// Fills `w` with a town keyframe (stamp 0) and two highway ones (0.5, 1.0), measured; returns
/// them.
std::vector<std::shared_ptr<Keyframe>> townThenHighway(KeyframeWindow* w) {
  std::vector<std::shared_ptr<Keyframe>> ks = {keyframe(0), keyframe(0.5), keyframe(1.0)};
  for (const auto& k : ks) w->add(k);
  w->storeInformation(ks, {kTown, kHighway, kHighway});
  return ks;
}

}  // namespace

TEST(CalibrationMonitor, StatesFollowTheEvidence) {
  MonitorSettings s;  // k 22.46, h 60, fresh 0.8
  s.change_span_s = 8;
  ExtrinsicMonitor m(s);
  EXPECT_EQ(m.status().state, MonitorState::kCalibrating);
  EXPECT_FALSE(m.observe(window(5), atChi2(500), kUnit));  // nothing published: nothing to check
  m.published(5, kI, kUnit);
  EXPECT_EQ(m.status().state, MonitorState::kCalibrated);
  EXPECT_TRUE(m.observe(window(9.5), atChi2(500), kUnit));  // 9 of 10 keyframes after 5 s: fresh
  EXPECT_EQ(m.status().state, MonitorState::kSuspect);
  EXPECT_DOUBLE_EQ(m.status().change_after, 9.5);
  EXPECT_NEAR(m.status().evidence, 40, 1e-9);  // 500 - 22.46, at most two thirds of h
  // Far beyond cusum_h, but 5 s of driving since `suspect` are less than the span's 8 s.
  EXPECT_FALSE(m.observe(window(14.5), atChi2(500), kUnit));
  EXPECT_EQ(m.status().state, MonitorState::kSuspect);
  EXPECT_TRUE(m.observe(window(19.5), atChi2(500), kUnit));
  EXPECT_EQ(m.status().state, MonitorState::kChanged);
  EXPECT_DOUBLE_EQ(m.status().since, 19.5);
  EXPECT_DOUBLE_EQ(m.status().change_after, 9.5);
  EXPECT_EQ(m.status().fresh_windows, 3);
  // `changed` holds: agreeing windows do not clear it (the estimate they agree with is gone).
  EXPECT_FALSE(m.observe(window(24.5), atChi2(0.1), kUnit));
  EXPECT_EQ(m.status().state, MonitorState::kChanged);
  m.restarted();
  EXPECT_EQ(m.status().state, MonitorState::kRecalibrating);
  EXPECT_FALSE(
      m.observe(window(29.5), atChi2(900), kUnit));  // the recalibration's windows are not checked
  m.published(29.5, atChi2(900), kUnit);
  EXPECT_EQ(m.status().state, MonitorState::kCalibrated);
  EXPECT_EQ(m.status().evidence, 0);
  // A second change (back to the identity) is bounded by its own windows, not the first run's.
  EXPECT_TRUE(m.observe(window(34.5), kI, kUnit));
  EXPECT_FALSE(m.observe(window(39.5), kI, kUnit));
  EXPECT_TRUE(m.observe(window(44.5), kI, kUnit));
  EXPECT_EQ(m.status().state, MonitorState::kChanged);
  EXPECT_EQ(m.status().changes, 2);
  EXPECT_DOUBLE_EQ(m.status().change_after, 34.5);
  m.reset();
  EXPECT_EQ(m.status().state, MonitorState::kCalibrating);
}

TEST(CalibrationMonitor, OneWindowFarOffDeclaresNothing) {
  // One window at chi2 900 (a solve gone astray), then windows that agree: the evidence it
  // raised drains, and no change is declared however long the span.
  MonitorSettings s;  // k 22.46, h 60, span 3 s
  ExtrinsicMonitor m(s);
  m.published(5, kI, kUnit);
  EXPECT_TRUE(m.observe(window(10), atChi2(900), kUnit));
  EXPECT_EQ(m.status().state, MonitorState::kSuspect);
  EXPECT_NEAR(m.status().evidence, 40, 1e-9);
  for (double t = 15; t <= 40; t += 5) {
    m.observe(window(t), atChi2(3), kUnit);
    EXPECT_NE(m.status().state, MonitorState::kChanged) << t;
  }
  EXPECT_EQ(m.status().state, MonitorState::kCalibrated);
  // Two such windows are a change.
  EXPECT_TRUE(m.observe(window(45), atChi2(900), kUnit));
  EXPECT_TRUE(m.observe(window(50), atChi2(900), kUnit));
  EXPECT_EQ(m.status().state, MonitorState::kChanged);
}

TEST(CalibrationMonitor, ASuspicionMeasuredThroughTheOtherExtrinsicIsDropped) {
  MonitorSettings s;  // k 22.46, h 60
  s.change_span_s = 0;
  ExtrinsicMonitor m(s);
  EXPECT_FALSE(m.isNew(1.0));  // nothing published: nothing is checked
  m.published(5, kI, kUnit);
  EXPECT_FALSE(m.isNew(5.0));
  EXPECT_TRUE(m.isNew(5.5));
  EXPECT_TRUE(m.observe(window(9.5), atChi2(40), kUnit));
  EXPECT_EQ(m.status().state, MonitorState::kSuspect);
  EXPECT_FALSE(m.isNew(9.5));
  EXPECT_TRUE(m.isNew(10.0));
  m.dropSuspicion();  // the other extrinsic was declared changed
  EXPECT_EQ(m.status().state, MonitorState::kCalibrated);
  EXPECT_EQ(m.status().evidence, 0);
  // The dropped window's evidence is gone: one more such window is a suspicion, not a change.
  EXPECT_TRUE(m.observe(window(14.5), atChi2(40), kUnit));
  EXPECT_EQ(m.status().state, MonitorState::kSuspect);
  EXPECT_NEAR(m.status().evidence, 40 - 22.46, 1e-9);
  EXPECT_DOUBLE_EQ(m.status().change_after, 14.5);
  // A change declared is not dropped.
  EXPECT_FALSE(m.observe(window(19.5), atChi2(500), kUnit));  // 17.5 + 40 at most
  EXPECT_TRUE(m.observe(window(24.5), atChi2(500), kUnit));
  EXPECT_EQ(m.status().state, MonitorState::kChanged);
  m.dropSuspicion();
  EXPECT_EQ(m.status().state, MonitorState::kChanged);
  EXPECT_TRUE(holdsChange(m.status()));
  EXPECT_FALSE(m.isNew(30.0));  // a changed extrinsic is not checked
}

TEST(CalibrationMonitor, AReferenceFromAFewKeyframesIsReplacedUntilAFullWindowIsPublished) {
  MonitorSettings s;  // k 22.46, h 60, fresh 0.8
  s.change_span_s = 0;
  ExtrinsicMonitor m(s);
  // The first estimate, from 3 keyframes, is off by chi2 500 from the rig's truth (the identity).
  m.published(1.0, atChi2(500), kUnit, false);
  EXPECT_EQ(m.status().state, MonitorState::kCalibrated);
  EXPECT_FALSE(m.observe(window(6), kI, kUnit));  // not checked against a provisional reference
  EXPECT_EQ(m.status().fresh_windows, 0);
  m.published(6, kI, kUnit, true);  // the full window's estimate becomes the reference
  for (double t : {11.0, 16.0, 21.0}) EXPECT_FALSE(m.observe(window(t), kI, kUnit));
  EXPECT_EQ(m.status().state, MonitorState::kCalibrated);
  EXPECT_EQ(m.status().fresh_windows, 3);
  // With the first estimate taken as the reference the same windows declare a change.
  ExtrinsicMonitor first(s);
  first.published(1.0, atChi2(500), kUnit);
  first.published(6, kI, kUnit);  // not from a fresh window counted: the reference stays
  for (double t : {11.0, 16.0}) first.observe(window(t), kI, kUnit);
  EXPECT_EQ(first.status().state, MonitorState::kChanged);
}

TEST(CalibrationMonitor, TheCusumAccumulatesOnlyFreshWindowsAndDrainsBack) {
  MonitorSettings s;
  s.cusum_k = 20;
  ExtrinsicMonitor m(s);
  m.published(5, kI, kUnit);
  EXPECT_TRUE(m.observe(window(10), atChi2(30), kUnit));  // +10
  EXPECT_EQ(m.status().state, MonitorState::kSuspect);
  EXPECT_NEAR(m.status().evidence, 10, 1e-12);
  // Overlapping windows (3 of 10 keyframes new) are not evidence of their own.
  EXPECT_FALSE(m.observe(window(11.5), atChi2(1000), kUnit));
  EXPECT_NEAR(m.status().evidence, 10, 1e-12);
  EXPECT_EQ(m.status().fresh_windows, 1);
  EXPECT_FALSE(m.observe(window(15), atChi2(25), kUnit));  // +5
  EXPECT_NEAR(m.status().evidence, 15, 1e-12);
  EXPECT_TRUE(m.observe(window(20), atChi2(4), kUnit));  // -16: back to 0
  EXPECT_EQ(m.status().state, MonitorState::kCalibrated);
  EXPECT_EQ(m.status().evidence, 0);
  EXPECT_EQ(m.status().fresh_windows, 3);
  EXPECT_NEAR(m.status().last_chi2, 4, 1e-12);
  // Estimates without a finite covariance are not compared.
  EXPECT_FALSE(m.observe(window(30), atChi2(900), kUnit * std::nan("")));
  EXPECT_EQ(m.status().fresh_windows, 3);
}

TEST(CalibrationMonitor, NoFalseAlarmUnderNoiseWithinTheCovariances) {
  // 10 minutes of driving with a solve after every keyframe (0.5 s), three times over.
  for (uint64_t seed : {1, 2, 3}) {
    std::mt19937_64 rng(seed);
    ExtrinsicMonitor m{MonitorSettings()};
    m.published(5, drawEstimate(Vector6d::Zero(), rng), windowCovariance());
    int suspect = 0;
    for (double t = 5.5; t < 605; t += 0.5) {
      const Eigen::Isometry3d T = drawEstimate(Vector6d::Zero(), rng);
      m.observe(window(t), T, windowCovariance());
      m.published(t, T, windowCovariance());  // every solve's estimate is published
      ASSERT_NE(m.status().state, MonitorState::kChanged) << "seed " << seed << " t " << t;
      suspect += m.status().state == MonitorState::kSuspect;
    }
    EXPECT_GT(m.status().fresh_windows, 100);
    EXPECT_LT(suspect, 60) << "seed " << seed;  // under 5 % of the 1200 solves
  }
}

TEST(CalibrationMonitor, DetectsAStepWithinTwoFreshWindows) {
  std::mt19937_64 rng(7);
  Vector6d step;  // 0.5 deg, 3 cm
  step << 0.3, -0.4, 0.0, 0.018, 0.0, -0.024;
  step.head<3>() /= kDegPerRad;
  ExtrinsicMonitor m{MonitorSettings()};
  m.published(5, drawEstimate(Vector6d::Zero(), rng), windowCovariance());
  double changed_at = -1, change_after = -1;
  for (double t = 5.5; t < 80 && changed_at < 0; t += 0.5) {
    // The window sees the step with the share of its keyframes after 30 s.
    const double share = std::clamp((t - 30.0) / 5.0, 0.0, 1.0);
    // Every solve's estimate is published until the monitor suspects a change: the reference
    // must not follow them across the step.
    const Eigen::Isometry3d T = drawEstimate(share * step, rng);
    m.observe(window(t), T, windowCovariance());
    if (m.status().state == MonitorState::kCalibrated) m.published(t, T, windowCovariance());
    if (t < 30) {
      ASSERT_EQ(m.status().state, MonitorState::kCalibrated) << t;
    }
    if (m.status().state == MonitorState::kChanged) {
      changed_at = t;
      change_after = m.status().change_after;
    }
  }
  EXPECT_GT(changed_at, 30);
  EXPECT_LE(changed_at, 40);
  EXPECT_GE(change_after, 30);  // the restart keeps no keyframe from before the step
  EXPECT_LT(change_after, changed_at);
}

/// With kUnit covariances: an estimate at `chi2` from the identity along y (a direction of its
/// own, so it is far from atChi2's along x).
Eigen::Isometry3d atChi2AlongY(double chi2) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation().y() = std::sqrt(2e-4 * chi2);
  return T;
}

TEST(CalibrationMonitor, WindowsThatSawTheOldExtrinsicAreNotAfterTheChange) {
  // A window at the old extrinsic raises the evidence a little (a false suspicion at 20 s), the
  // next still agrees with the old extrinsic, then the step: the keyframes up to the newest of
  // the last window that disagrees with the new estimate are before the change.
  MonitorSettings s;  // k 22.46, h 60, span 3 s
  ExtrinsicMonitor m(s);
  m.published(10, kI, kUnit);
  EXPECT_FALSE(m.observe(window(15), atChi2(5), kUnit));  // agrees: calibrated
  EXPECT_TRUE(m.observe(window(20), atChi2(40), kUnit));
  EXPECT_EQ(m.status().state, MonitorState::kSuspect);
  EXPECT_DOUBLE_EQ(m.status().change_after, 20);
  EXPECT_FALSE(m.observe(window(25), atChi2(15), kUnit));  // evidence 17.5 - 7.5: still > 0
  EXPECT_EQ(m.status().state, MonitorState::kSuspect);
  EXPECT_FALSE(m.observe(window(30), atChi2AlongY(400), kUnit));  // + 40 at most: 50.1
  EXPECT_TRUE(m.observe(window(35), atChi2AlongY(400), kUnit));
  EXPECT_EQ(m.status().state, MonitorState::kChanged);
  EXPECT_DOUBLE_EQ(m.status().change_after, 25);
  // The same run whose windows all agree with the declaring estimate (they saw the new
  // extrinsic): the first window that raised the evidence bounds the change.
  ExtrinsicMonitor all_after(s);
  all_after.published(10, kI, kUnit);
  all_after.observe(window(20), atChi2AlongY(50), kUnit);
  all_after.observe(window(25), atChi2AlongY(51), kUnit);
  all_after.observe(window(30), atChi2AlongY(52), kUnit);
  EXPECT_EQ(all_after.status().state, MonitorState::kChanged);
  EXPECT_DOUBLE_EQ(all_after.status().change_after, 20);
}

TEST(CalibrationMonitor, ANewerHalfThatDeclaresTheChangeLeavesItsOlderHalfBehind) {
  MonitorSettings s;
  ExtrinsicMonitor m(s);
  m.published(10, kI, kUnit);
  EXPECT_TRUE(m.observe(window(20), atChi2(100), kUnit));
  // A straddling window's newer half (its last 5 keyframes, 27.5-29.5 s): the keyframes before
  // it go, even though the first suspect window's newest is older.
  const std::vector<double> half = {27.5, 28.0, 28.5, 29.0, 29.5};
  EXPECT_TRUE(m.observe(half, atChi2(100), kUnit, true));
  EXPECT_EQ(m.status().state, MonitorState::kChanged);
  EXPECT_LT(m.status().change_after, 27.5);
  EXPECT_GT(m.status().change_after, 27.4999);
  // The same estimate from a whole window says nothing of which of its keyframes came after.
  ExtrinsicMonitor whole(s);
  whole.published(10, kI, kUnit);
  whole.observe(window(20), atChi2(100), kUnit);
  whole.observe(half, atChi2(100), kUnit);
  EXPECT_DOUBLE_EQ(whole.status().change_after, 20);
}

TEST(CalibrationMonitor, ARestartedWindowKeepsOnlyTheKeyframesAfterTheChange) {
  for (const char* selection : {"fifo", "information"}) {
    KeyframeWindow w(10, selection);
    for (int i = 0; i < 12; ++i) {
      auto k = std::make_shared<Keyframe>();
      k->stamp = 0.5 * i;
      w.add(k);
    }
    ASSERT_EQ(w.size(), 10u);
    EXPECT_EQ(w.dropUpTo(3.5), 4u) << selection;  // 4.0 4.5 5.0 5.5
    EXPECT_EQ(w.stamps(), (std::vector<double>{4.0, 4.5, 5.0, 5.5})) << selection;
    EXPECT_EQ(w.dropUpTo(-1), 4u);
  }
}

TEST(CalibrationMonitor, WhileSuspectTheOldestKeyframeLeavesTheWindow) {
  // A town keyframe (informative in every direction) and highway keyframes (nothing along z):
  // by information the town keyframe stays and a highway one leaves; oldest-first (while a
  // change is suspected) lets the town keyframe go, so new windows become fresh.
  for (bool oldest_first : {false, true}) {
    KeyframeWindow w(3, "information");
    townThenHighway(&w);
    w.setOldestFirst(oldest_first);
    w.add(keyframe(1.5));
    EXPECT_EQ(w.stamps(), oldest_first ? (std::vector<double>{0.5, 1.0, 1.5})
                                       : (std::vector<double>{0.0, 1.0, 1.5}));
    EXPECT_EQ(w.setAside(), oldest_first ? 1u : 0u);
  }
}

TEST(CalibrationMonitor, KeyframesSetAsideWhileSuspectComeBackUnlessBeforeTheChange) {
  // While suspect the town keyframe (stamp 0) leaves a window of three for a highway one; when
  // the suspicion clears it comes back and, by information, a highway keyframe leaves instead.
  // After a change the window drops what came before it, the set-aside keyframes included.
  for (bool changed : {false, true}) {
    KeyframeWindow w(3, "information");
    std::vector<std::shared_ptr<Keyframe>> ks = townThenHighway(&w);
    w.setOldestFirst(true);
    ks.push_back(keyframe(1.5));
    w.add(ks.back());
    w.storeInformation({ks[1], ks[2], ks[3]}, {kHighway, kHighway, kHighway});
    EXPECT_EQ(w.stamps(), (std::vector<double>{0.5, 1.0, 1.5}));
    if (changed) {
      EXPECT_EQ(w.dropUpTo(0.5), 2u);
    }
    w.setOldestFirst(false);
    EXPECT_EQ(w.setAside(), 0u);
    EXPECT_EQ(w.stamps(),
              changed ? (std::vector<double>{1.0, 1.5}) : (std::vector<double>{0.0, 1.0, 1.5}));
  }
}

TEST(CalibrationMonitor, AWeakDirectionOfTheWindowRaisesNoAlarm) {
  // Highway windows hardly constrain t_z (sigma 10 cm here): their estimates wander 5 cm along it
  // from window to window, and the chi2 against both covariances stays small. The same wander
  // where the windows constrain t_z to 5 mm is a change.
  for (const double sigma_tz : {0.10, 0.005}) {
    Matrix6d P = windowCovariance();
    P(5, 5) = sigma_tz * sigma_tz;
    ExtrinsicMonitor m{MonitorSettings()};
    m.published(5, kI, P);
    bool changed = false;
    for (double t = 5.5; t < 65; t += 0.5) {
      Eigen::Isometry3d T = kI;
      T.translation().z() = (static_cast<int>(t / 3) % 2 ? 0.05 : -0.05);
      m.observe(window(t), T, P);
      m.published(t, T, P);
      changed = changed || m.status().state == MonitorState::kChanged;
    }
    EXPECT_EQ(changed, sigma_tz < 0.01) << "sigma_tz " << sigma_tz;
  }
}

TEST(CalibrationMonitor, ADirectionTheWindowLeavesUnconstrainedIsLeftOut) {
  // Highway windows whose covariance claims 7 mm along t_z while the trust check finds t_z
  // beyond its limit: their estimates 7 cm off along t_z count for nothing when that direction is
  // passed as unconstrained, and are a change when it is not. The same 7 cm along t_x, which the
  // windows constrain, is a change either way.
  Matrix6d P = windowCovariance();
  P(5, 5) = 0.007 * 0.007;
  const std::vector<Vector6d> loose = {Vector6d::Unit(5)};
  struct Case {
    int axis;
    bool pass_loose, changes;
  };
  for (const Case& c : {Case{5, true, false}, Case{5, false, true}, Case{3, true, true}}) {
    ExtrinsicMonitor m{MonitorSettings()};
    m.published(5, kI, P);
    Eigen::Isometry3d T = kI;
    T.translation()(c.axis - 3) = 0.07;
    bool changed = false;
    for (double t = 10; t < 70; t += 5) {  // non-overlapping windows
      m.observe(window(t), T, P, false, c.pass_loose ? loose : std::vector<Vector6d>{});
      changed = changed || m.status().state == MonitorState::kChanged;
    }
    EXPECT_EQ(changed, c.changes) << "axis " << c.axis << (c.pass_loose ? ", t_z left out" : "");
  }
}

TEST(CalibrationMonitor, ANewerHalfLeavesOutWhatItDoesNotConstrain) {
  // A window whose halves disagree gives the monitor its newer half's estimate, without the
  // directions that half leaves beyond the trust limits (here t_z, 3 cm against the 1 cm limit,
  // while the half's covariance says 7 mm): 7 cm along t_z is then no change, 7 cm along t_x is.
  std::vector<std::shared_ptr<Keyframe>> ks;
  for (int i = 0; i < 6; ++i) ks.push_back(keyframe(10 + 0.5 * i));
  Matrix6d P = windowCovariance();
  P(5, 5) = 0.007 * 0.007;
  Matrix6d loose = windowCovariance();
  loose(5, 5) = 0.03 * 0.03;
  const LidarStereoSettings settings;
  LidarStereoResult r;
  r.halves.tested = true;
  r.halves.chi2 = 2 * settings.halves_chi2_limit;
  r.halves.second_settled = true;
  r.halves.second_begin = 3;
  r.halves.second_covariance = P;
  r.halves.second_weak_directions =
      weakDirections(loose, settings.max_sigma_rot_deg, settings.max_sigma_trans_m);
  const std::optional<NewerHalfEstimate> half = newerHalf(r, settings, ks);
  ASSERT_TRUE(half.has_value());
  EXPECT_EQ(half->stamps, (std::vector<double>{11.5, 12.0, 12.5}));
  ASSERT_EQ(half->unconstrained.size(), 1u);
  EXPECT_GT(std::fabs(half->unconstrained[0].normalized()(5)), 0.999);
  for (const int axis : {5, 3}) {
    ExtrinsicMonitor m{MonitorSettings()};
    m.published(5, kI, P);
    Eigen::Isometry3d T = kI;
    T.translation()(axis - 3) = 0.07;
    bool changed = false;
    for (double t = 10; t < 70; t += 5) {
      std::vector<double> stamps = half->stamps;
      for (double& s : stamps) s += t;
      m.observe(stamps, T, P, true, half->unconstrained);
      changed = changed || m.status().state == MonitorState::kChanged;
    }
    EXPECT_EQ(changed, axis == 3) << "axis " << axis;
  }
  // A half within the limits everywhere leaves nothing out; halves that agree give no half.
  r.halves.second_weak_directions =
      weakDirections(P, settings.max_sigma_rot_deg, settings.max_sigma_trans_m);
  EXPECT_TRUE(newerHalf(r, settings, ks)->unconstrained.empty());
  r.halves.chi2 = 0.5 * settings.halves_chi2_limit;
  EXPECT_FALSE(newerHalf(r, settings, ks).has_value());
}

TEST(PublishPolicy, ARecalibrationIsNotHeldToTheChangedEstimatesCovariance) {
  // Once the monitor declared the published extrinsic changed, that estimate's covariance says how
  // well the old rig was known: a full window's estimate of the new one is published even when
  // it is less certain than the old (max_variance_growth would keep the changed one for good).
  OnlineEstimate old_one, candidate;
  for (OnlineEstimate* e : {&old_one, &candidate}) {
    e->converged = true;
    e->keyframes_used = 10;
  }
  old_one.cov_lidar = Matrix6d::Identity() * 1e-8;
  candidate.cov_lidar = Matrix6d::Identity() * 4e-8;  // variance 4x, above the growth of 2
  const OnlineSettings s;
  ASSERT_LT(s.max_variance_growth, 4.0);
  ASSERT_EQ(s.window_size, 10);
  const std::optional<OnlineEstimate> published = old_one;
  EXPECT_NE(publicationRefusal(candidate, published, s, "").find("less certain than the published"),
            std::string::npos);
  EXPECT_EQ(publicationRefusal(candidate, published, s, "", true), "");
  // Still only from a window as full as the published estimate's.
  candidate.keyframes_used = 4;
  EXPECT_NE(publicationRefusal(candidate, published, s, "", true)
                .find("from 4 keyframes, fewer than the published estimate's 10"),
            std::string::npos);
}
