#include "tescalib/core/validation/optimum_uncertainty.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Eigenvalues>

#include "tescalib/core/validation/validation.h"

namespace tescalib {
namespace {

/// Per-frame scores of one criterion, oriented so that larger is better.
class OrientedScores {
 public:
  OrientedScores(ValidationSet& set, Criterion c, const Eigen::Isometry3d& T,
                 const Eigen::Isometry3d& T_right_left)
      : set_(set),
        c_(c),
        T_(T),
        T_right_left_(T_right_left),
        step_(validationStep(set.settings())) {}

  /// At the optimum moved by `steps` (in multiples of the settings' step per axis).
  std::vector<double> at(const Vector6d& steps) const {
    return betterScores(set_, c_, perturb(T_, steps.cwiseProduct(step_)), T_right_left_);
  }
  const Vector6d& step() const { return step_; }

 private:
  ValidationSet& set_;
  Criterion c_;
  Eigen::Isometry3d T_, T_right_left_;
  Vector6d step_;
};

/// Per frame: the gradient and the Hessian (in steps) by central differences.
void frameDerivatives(const OrientedScores& s, std::vector<Vector6d>* g, std::vector<Matrix6d>* H) {
  const std::vector<double> s0 = s.at(Vector6d::Zero());
  const size_t F = s0.size();
  g->assign(F, Vector6d::Zero());
  H->assign(F, Matrix6d::Zero());
  for (int k = 0; k < 6; ++k) {
    const std::vector<double> p = s.at(Vector6d::Unit(k)), m = s.at(-Vector6d::Unit(k));
    for (size_t f = 0; f < F; ++f) {
      (*g)[f](k) = 0.5 * (p[f] - m[f]);
      (*H)[f](k, k) = p[f] + m[f] - 2 * s0[f];
    }
    for (int l = 0; l < k; ++l) {
      const std::vector<double> pp = s.at(Vector6d::Unit(k) + Vector6d::Unit(l)),
                                pm = s.at(Vector6d::Unit(k) - Vector6d::Unit(l)),
                                mp = s.at(-Vector6d::Unit(k) + Vector6d::Unit(l)),
                                mm = s.at(-Vector6d::Unit(k) - Vector6d::Unit(l));
      for (size_t f = 0; f < F; ++f)
        (*H)[f](k, l) = (*H)[f](l, k) = 0.25 * (pp[f] - pm[f] - mp[f] + mm[f]);
    }
  }
}

/// Whether the frames' curvature along v (how much worse a step along it makes each frame) is
/// significantly positive.
bool curvesDown(const std::vector<Matrix6d>& H, const Vector6d& v) {
  std::vector<double> q;
  for (const Matrix6d& h : H) q.push_back(-v.dot(h * v));
  const ScoreSummary s = summarize(q);
  return s.mean > 0 && significant(s);
}

/// The pseudo-inverse of a covariance over the resolved subspace (projector P).
Matrix6d resolvedInverse(const Matrix6d& cov, const Matrix6d& P) {
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(0.5 * (cov + cov.transpose()));
  const double tiny = 1e-12 * std::max(1e-300, eig.eigenvalues().maxCoeff());
  Matrix6d info = Matrix6d::Zero();
  for (int i = 0; i < 6; ++i) {
    const Vector6d v = eig.eigenvectors().col(i);
    if (eig.eigenvalues()(i) > tiny && (P * v).norm() > 0.5)
      info += v * v.transpose() / eig.eigenvalues()(i);
  }
  return info;
}

}  // namespace

OptimumUncertainty optimumUncertainty(ValidationSet& set, Criterion c,
                                      const Eigen::Isometry3d& T_optimum,
                                      const Eigen::Isometry3d& T_right_left) {
  OptimumUncertainty u;
  const OrientedScores scores(set, c, T_optimum, T_right_left);
  std::vector<Vector6d> g;
  std::vector<Matrix6d> H;
  frameDerivatives(scores, &g, &H);
  u.frames = static_cast<int>(g.size());
  u.sigma.setConstant(std::numeric_limits<double>::infinity());
  if (u.frames < 3) return u;
  Vector6d g_mean = Vector6d::Zero();
  Matrix6d A = Matrix6d::Zero();  // minus the mean Hessian: positive definite at a maximum
  for (int f = 0; f < u.frames; ++f) {
    g_mean += g[f] / u.frames;
    A -= H[f] / u.frames;
  }
  Matrix6d B = Matrix6d::Zero();  // the covariance of the mean gradient
  for (const Vector6d& gf : g) B += (gf - g_mean) * (gf - g_mean).transpose();
  B /= double(u.frames - 1) * u.frames;
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(0.5 * (A + A.transpose()));
  Matrix6d A_pinv = Matrix6d::Zero(), P_resolved = Matrix6d::Zero();
  std::array<bool, 6> unresolved_axis{};
  for (int i = 0; i < 6; ++i) {
    const Vector6d v = eig.eigenvectors().col(i);
    if (eig.eigenvalues()(i) > 0 && curvesDown(H, v)) {
      A_pinv += v * v.transpose() / eig.eigenvalues()(i);
      P_resolved += v * v.transpose();
      ++u.rank;
    } else {
      for (int k = 0; k < 6; ++k) unresolved_axis[k] = unresolved_axis[k] || std::fabs(v(k)) > 0.3;
    }
  }
  const Matrix6d D = scores.step().asDiagonal();
  const Matrix6d D_inv = scores.step().cwiseInverse().asDiagonal();
  const Vector6d floor = set.settings().optimum_floor[static_cast<int>(c)];
  const Matrix6d floor_steps = D_inv * Matrix6d(floor.cwiseProduct(floor).asDiagonal()) * D_inv;
  const Matrix6d stat_steps = A_pinv * B * A_pinv;
  const Matrix6d cov_steps = stat_steps + floor_steps;
  u.statistical = D * stat_steps * D;
  u.covariance = D * cov_steps * D;
  u.information = D_inv * resolvedInverse(P_resolved * cov_steps * P_resolved, P_resolved) * D_inv;
  for (int k = 0; k < 6; ++k) {
    u.resolved[k] = !unresolved_axis[k];
    if (u.resolved[k]) u.sigma(k) = std::sqrt(std::max(0.0, u.covariance(k, k)));
  }
  return u;
}

double OptimumUncertainty::chi2(const Eigen::Isometry3d& T_optimum,
                                const Eigen::Isometry3d& T) const {
  const Vector6d e = poseError(T, T_optimum);
  return e.dot(information * e);
}

}  // namespace tescalib
