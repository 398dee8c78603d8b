#include "tescalib/core/uncertainty/trust.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/QR>

namespace tescalib {

double nees(const Vector6d& error, const Matrix6d& covariance) {
  const Eigen::LLT<Matrix6d> llt(covariance);
  return llt.info() == Eigen::Success ? error.dot(llt.solve(error)) : std::nan("");
}

double neesIgnoring(const Vector6d& error, const Matrix6d& covariance,
                    const std::vector<Vector6d>& ignored) {
  if (ignored.empty()) return nees(error, covariance);
  const Eigen::LLT<Matrix6d> llt(covariance);
  if (llt.info() != Eigen::Success) return std::nan("");
  // P = S^-1; the limit of (S + lambda W W^T)^-1 for lambda -> infinity is
  // P - P W (W^T P W)^+ W^T P.
  Eigen::Matrix<double, 6, Eigen::Dynamic> W(6, static_cast<int>(ignored.size()));
  for (size_t j = 0; j < ignored.size(); ++j) W.col(static_cast<int>(j)) = ignored[j];
  const Vector6d Pe = llt.solve(error);
  const Eigen::MatrixXd PW = llt.solve(W);
  const Eigen::VectorXd b = W.transpose() * Pe;
  const Eigen::MatrixXd A = W.transpose() * PW;
  const Eigen::VectorXd x = A.completeOrthogonalDecomposition().solve(b);
  return std::max(0.0, error.dot(Pe) - b.dot(x));
}

void addAxisVariances(Matrix6d* covariance, const std::array<double, 3>& sigma_rot_deg,
                      const std::array<double, 3>& sigma_trans_m) {
  for (int i = 0; i < 3; ++i) {
    (*covariance)(i, i) += std::pow(sigma_rot_deg[i] / kDegPerRad, 2);
    (*covariance)(3 + i, 3 + i) += std::pow(sigma_trans_m[i], 2);
  }
}

bool axesWithin(const Matrix6d& covariance, double max_sigma_rot_deg, double max_sigma_trans_m,
                bool trusted[6]) {
  bool all = true;
  for (int i = 0; i < 6; ++i) {
    const double limit = i < 3 ? max_sigma_rot_deg / kDegPerRad : max_sigma_trans_m;
    trusted[i] = std::sqrt(covariance(i, i)) < limit;
    all = all && trusted[i];
  }
  return all;
}

namespace {
/// `d` or -d, whichever has its largest component positive (a direction's one sign).
Vector6d largestPositive(const Vector6d& d) {
  Eigen::Index largest;
  d.cwiseAbs().maxCoeff(&largest);
  return d[largest] < 0 ? Vector6d(-d) : d;
}
}  // namespace

Vector6d limitScale(double max_sigma_rot_deg, double max_sigma_trans_m) {
  Vector6d scale;
  scale << Eigen::Vector3d::Constant(kDegPerRad / max_sigma_rot_deg),
      Eigen::Vector3d::Constant(1.0 / max_sigma_trans_m);
  return scale;
}

Matrix6d inLimitUnits(const Matrix6d& map, const Vector6d& scale) {
  return scale.asDiagonal() * map * scale.cwiseInverse().asDiagonal();
}

WeakDirection weakDirectionAlong(const Vector6d& v) {
  WeakDirection w;
  w.ratio = v.norm();
  if (w.ratio > 0) w.direction = largestPositive(v / w.ratio);
  return w;
}

std::vector<Vector6d> beyondLimits(const std::vector<WeakDirection>& directions,
                                   double max_sigma_rot_deg, double max_sigma_trans_m) {
  const Vector6d scale = limitScale(max_sigma_rot_deg, max_sigma_trans_m);
  std::vector<Vector6d> out;
  for (const WeakDirection& w : directions)
    if (w.ratio > 1) out.push_back(w.direction.cwiseQuotient(scale));
  return out;
}

std::vector<WeakDirection> weakDirections(const Matrix6d& covariance, double max_sigma_rot_deg,
                                          double max_sigma_trans_m) {
  if (!covariance.allFinite() || !(max_sigma_rot_deg > 0) || !(max_sigma_trans_m > 0)) return {};
  const Vector6d scale = limitScale(max_sigma_rot_deg, max_sigma_trans_m);
  Matrix6d scaled = scale.asDiagonal() * covariance * scale.asDiagonal();
  scaled = 0.5 * (scaled + scaled.transpose()).eval();
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(scaled);
  std::vector<WeakDirection> out;
  for (int i = 5; i >= 0; --i) {  // eigenvalues ascending: the weakest last
    WeakDirection w;
    w.ratio = std::sqrt(std::max(0.0, eig.eigenvalues()[i]));
    w.direction = largestPositive(eig.eigenvectors().col(i));
    out.push_back(w);
  }
  return out;
}

std::string describeDirection(const Vector6d& direction) {
  static const char* names[6] = {"rx", "ry", "rz", "tx", "ty", "tz"};
  std::array<int, 6> order = {0, 1, 2, 3, 4, 5};
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return std::fabs(direction[a]) > std::fabs(direction[b]); });
  std::string out;
  char buf[32];
  for (int i : order) {
    const double c = direction[i];
    if (std::fabs(c) < 0.2) break;
    if (out.empty())
      std::snprintf(buf, sizeof buf, "%.2f %s", c, names[i]);
    else
      std::snprintf(buf, sizeof buf, " %c %.2f %s", c < 0 ? '-' : '+', std::fabs(c), names[i]);
    out += buf;
  }
  return out;
}

std::string describeWeakest(const WeakDirection& weakest) {
  if (!(weakest.ratio > 0)) return "";
  char buf[48];
  // %.2f up to a million; beyond, %.3g (a near-singular covariance's ratio would not fit).
  std::snprintf(buf, sizeof buf,
                weakest.ratio < 1e6 ? ", %.2fx the trust limit" : ", %.3gx the trust limit",
                weakest.ratio);
  return describeDirection(weakest.direction) + buf;
}

std::string weakestClause(const std::vector<WeakDirection>& directions) {
  return directions.empty() ? "" : "; weakest direction " + describeWeakest(directions.front());
}

std::string untrustedAxes(const bool trusted[6]) {
  static const char* kAxes[6] = {"rx", "ry", "rz", "tx", "ty", "tz"};
  std::string out;
  for (int i = 0; i < 6; ++i)
    if (!trusted[i]) out += std::string(out.empty() ? "" : " ") + kAxes[i];
  return out;
}

}  // namespace tescalib
