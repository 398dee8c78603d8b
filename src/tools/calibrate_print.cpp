#include "calibrate_print.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "tescalib/core/common/pose_format.h"

namespace tescalib::calibrate {

std::string pose6(const Vector6d& v) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "[%+.4f %+.4f %+.4f] deg, [%+.2f %+.2f %+.2f] cm",
                v(0) * kDegPerRad, v(1) * kDegPerRad, v(2) * kDegPerRad, 100 * v(3), 100 * v(4),
                100 * v(5));
  return buf;
}

namespace {

std::string sigma6(const Matrix6d& cov) {
  Vector6d s;
  for (int i = 0; i < 6; ++i) s(i) = std::sqrt(std::max(0.0, cov(i, i)));
  std::string out = pose6(s);
  for (char& c : out)
    if (c == '+') c = ' ';
  return out;
}

/// "0.1 deg and 1 cm": the limits as a reader writes them.
std::string limits(const ExtrinsicReport& r) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%g deg and %g cm (1 sigma)", r.limit_rot_deg,
                100 * r.limit_trans_m);
  return buf;
}

}  // namespace

std::string trustLine(const ExtrinsicReport& r) {
  if (!r.covariance_known) return "trusted: no - the solve ended before its covariance";
  const std::string weak = untrustedAxes(r.observable);
  if (!weak.empty())
    return "trusted: no - " + weak +
           (weak.size() > 2 ? " looser than their limits of " : " looser than its limit of ") +
           limits(r);
  if (!r.published)
    return "trusted: no - every axis is within " + limits(r) +
           ", but the solve was not published (its message above says why)";
  return "trusted: yes, every axis within " + limits(r);
}

void printExtrinsic(const ExtrinsicReport& r) {
  std::printf("%s, %s\n", r.title, describeTransform(r.parent, r.child, r.T_a_b.inverse()).c_str());
  if (r.node_parameter) {
    const Eigen::Vector3d& t = r.T_a_b.translation();
    Eigen::Quaterniond q(r.T_a_b.linear());
    if (q.w() < 0) q.coeffs() *= -1;
    std::printf("  as the node's %s (the inverse): [%.4f, %.4f, %.4f, %.6f, %.6f, %.6f, %.6f]\n",
                r.node_parameter, t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
  }
  if (r.covariance_known)
    std::printf("  sigma %s (about and along %s's x y z)\n", sigma6(r.cov).c_str(),
                r.child.c_str());
  std::printf("  %s\n", trustLine(r).c_str());
  if (r.weakest.ratio > 0)
    std::printf("  weakest direction %s (above 1: looser than the limits)\n",
                describeWeakest(r.weakest).c_str());
}

}  // namespace tescalib::calibrate
