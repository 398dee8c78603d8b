#include "tescalib/core/validation/validation.h"

#include <cmath>
#include <limits>

namespace tescalib {
namespace {

/// The two-sided 95 % quantiles of Student's t for 1..30 degrees of freedom.
constexpr double kT95[30] = {12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228,
                             2.201,  2.179, 2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086,
                             2.080,  2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045, 2.042};

/// The criterion's mean score, oriented so that larger is better.
double betterScore(ValidationSet& set, Criterion c, const Eigen::Isometry3d& T,
                   const Eigen::Isometry3d& T_right_left) {
  return summarize(betterScores(set, c, T, T_right_left)).mean;
}

/// The finite differences of one criterion along axis k from the per-frame scores at the pose and
/// a step either way.
void differences(const std::vector<double>& s0, const std::vector<double>& plus,
                 const std::vector<double>& minus, bool higher_better, int k,
                 CriterionValidation* out) {
  std::vector<double> g(s0.size()), q(s0.size()), zero(s0.size(), 0.0);
  for (size_t f = 0; f < s0.size(); ++f) {
    g[f] = 0.5 * (plus[f] - minus[f]);
    q[f] = 0.5 * (plus[f] + minus[f]) - s0[f];
  }
  const ScoreSummary gs = pairedDifference(g, zero), qs = pairedDifference(q, zero);
  out->gradient(k) = gs.mean;
  out->gradient_se(k) = gs.standard_error;
  out->curvature(k) = qs.mean;
  out->curvature_se(k) = qs.standard_error;
  out->sensitivity(k) = 0.5 * (std::fabs(gs.mean + qs.mean) + std::fabs(qs.mean - gs.mean));
  const bool g_sig = significant(gs);
  out->direction[k] = g_sig ? ((gs.mean > 0) == higher_better ? 1 : -1) : 0;
  out->sees[k] = g_sig || significant(qs);
}

/// Samples the criterion at -4..4 times `direction` around *T, refines the best sample with a
/// parabola and moves *T there; returns the move in multiples of `direction`.
double lineSearch(ValidationSet& set, Criterion c, const Eigen::Isometry3d& T_right_left,
                  const Vector6d& direction, Eigen::Isometry3d* T) {
  std::array<double, 9> s;
  int best = 4;
  for (int j = 0; j < 9; ++j) {
    s[j] = betterScore(set, c, perturb(*T, (j - 4) * direction), T_right_left);
    if (s[j] > s[best]) best = j;
  }
  double offset = best - 4;
  if (best > 0 && best < 8) {
    const double den = s[best - 1] - 2 * s[best] + s[best + 1];
    if (den < 0) offset += 0.5 * (s[best - 1] - s[best + 1]) / den;
  }
  *T = perturb(*T, offset * direction);
  return offset;
}

}  // namespace

std::vector<double> betterScores(ValidationSet& set, Criterion c, const Eigen::Isometry3d& T,
                                 const Eigen::Isometry3d& T_right_left) {
  std::vector<double> s = set.score(T, T_right_left, {c})[static_cast<int>(c)];
  if (!higherIsBetter(c))
    for (double& v : s) v = -v;
  return s;
}

ScoreSummary summarize(const std::vector<double>& values) {
  ScoreSummary s;
  s.frames = static_cast<int>(values.size());
  if (values.empty()) return s;
  for (double v : values) s.mean += v;
  s.mean /= values.size();
  if (values.size() < 2) return s;
  double ss = 0;
  for (double v : values) ss += (v - s.mean) * (v - s.mean);
  s.standard_error = std::sqrt(ss / (values.size() - 1) / values.size());
  return s;
}

ScoreSummary pairedDifference(const std::vector<double>& a, const std::vector<double>& b) {
  std::vector<double> d(std::min(a.size(), b.size()));
  for (size_t i = 0; i < d.size(); ++i) d[i] = a[i] - b[i];
  return summarize(d);
}

double significanceFactor(int frames) {
  if (frames < 2) return std::numeric_limits<double>::infinity();
  return frames - 1 <= 30 ? kT95[frames - 2] : 1.96;
}

bool significant(const ScoreSummary& s) {
  return s.frames >= 2 && std::fabs(s.mean) > significanceFactor(s.frames) * s.standard_error;
}

Vector6d validationStep(const ValidationSettings& s) {
  const double r = s.step_rot_deg / kDegPerRad, t = s.step_trans_m;
  return (Vector6d() << r, r, r, t, t, t).finished();
}

Validation validateCalibration(ValidationSet& set, const Eigen::Isometry3d& T_cam_lidar,
                               const Eigen::Isometry3d& T_right_left, bool sensitivities) {
  Validation v;
  v.frames = set.score(T_cam_lidar, T_right_left);
  for (Criterion c : kAllCriteria)
    v.criteria[static_cast<int>(c)].score = summarize(v.frames[static_cast<int>(c)]);
  if (!sensitivities) return v;
  const Vector6d step = validationStep(set.settings());
  for (int k = 0; k < 6; ++k) {
    const FrameScores plus =
        set.score(perturb(T_cam_lidar, Vector6d::Unit(k) * step(k)), T_right_left);
    const FrameScores minus =
        set.score(perturb(T_cam_lidar, -Vector6d::Unit(k) * step(k)), T_right_left);
    for (Criterion c : kAllCriteria) {
      const int i = static_cast<int>(c);
      differences(v.frames[i], plus[i], minus[i], higherIsBetter(c), k, &v.criteria[i]);
    }
  }
  return v;
}

Eigen::Isometry3d criterionOptimum(ValidationSet& set, Criterion c,
                                   const Eigen::Isometry3d& T_start,
                                   const Eigen::Isometry3d& T_right_left, int rounds) {
  Eigen::Isometry3d T = T_start;
  Vector6d step = 4.0 * validationStep(set.settings());
  for (int round = 0; round < rounds; ++round, step *= 0.5) {
    for (int sweep = 0; sweep < 3; ++sweep) {
      Vector6d moved = Vector6d::Zero();  // in steps
      for (int k = 0; k < 6; ++k) {
        const double s = lineSearch(set, c, T_right_left, Vector6d::Unit(k) * step(k), &T);
        moved(k) = s;
      }
      // Powell's extra direction: the sweep's net move, along which a valley of two correlated
      // axes (a pitch and a vertical shift) runs.
      if (moved.norm() > 0.5)
        lineSearch(set, c, T_right_left, moved.cwiseProduct(step) / moved.norm(), &T);
      if (moved.cwiseAbs().maxCoeff() < 0.5) break;
    }
  }
  return T;
}

}  // namespace tescalib
