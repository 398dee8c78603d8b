#include "tescalib/core/eval/disparity_signatures.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Core>

#include "tescalib/core/common/statistics.h"

namespace tescalib {

namespace {

bool kept(const DisparitySample& s) {
  return std::fabs(s.difference_px) <= DisparityResidual::kMaxDifferencePx;
}

/// The ring medians, the rings that have one, and the jumps between neighbouring ones.
void ringSignature(const std::vector<DisparitySample>& samples, DisparitySignatures* out) {
  std::vector<std::vector<double>> by_ring;
  for (const DisparitySample& s : samples) {
    if (!kept(s) || s.ring < 0) continue;
    if (s.ring >= static_cast<int>(by_ring.size())) by_ring.resize(s.ring + 1);
    by_ring[s.ring].push_back(s.difference_px);
  }
  const int n = static_cast<int>(by_ring.size());
  out->ring_median_px.assign(n, 0.0);
  out->ring_points.assign(n, 0);
  std::vector<bool> qualifies(n, false);
  std::vector<double> medians;
  for (int r = 0; r < n; ++r) {
    out->ring_points[r] = static_cast<int>(by_ring[r].size());
    qualifies[r] = out->ring_points[r] >= DisparitySignatures::kMinRingPoints;
    if (!qualifies[r]) continue;
    out->ring_median_px[r] = medianOf(by_ring[r]);
    medians.push_back(out->ring_median_px[r]);
  }
  out->rings = static_cast<int>(medians.size());
  if (!medians.empty()) {
    out->ring_min_median_px = *std::min_element(medians.begin(), medians.end());
    out->ring_max_median_px = *std::max_element(medians.begin(), medians.end());
  }
  std::vector<double> jumps;
  for (int r = 0; r + 1 < n; ++r) {
    if (!qualifies[r] || !qualifies[r + 1]) continue;
    jumps.push_back(std::fabs(out->ring_median_px[r + 1] - out->ring_median_px[r]));
    if (jumps.back() > out->ring_max_jump_px)
      out->ring_max_jump_px = jumps.back(), out->ring_max_jump_ring = r;
  }
  out->ring_pairs = static_cast<int>(jumps.size());
  out->ring_jump_px = medianOf(jumps);
}

}  // namespace

DisparityFit fitDisparityOffsetAndScale(const std::vector<DisparitySample>& samples) {
  std::vector<const DisparitySample*> used;
  for (const DisparitySample& s : samples)
    if (kept(s)) used.push_back(&s);
  DisparityFit fit;
  fit.points = static_cast<int>(used.size());
  if (fit.points < 2) return fit;
  std::vector<double> w(used.size(), 1.0), abs_e(used.size());
  Eigen::Vector2d x = Eigen::Vector2d::Zero();
  for (int it = 0; it < 50; ++it) {
    Eigen::Matrix2d A = Eigen::Matrix2d::Zero();
    Eigen::Vector2d b = Eigen::Vector2d::Zero();
    for (size_t i = 0; i < used.size(); ++i) {
      const Eigen::Vector2d j(1.0, used[i]->lidar_px);
      A += w[i] * j * j.transpose();
      b += w[i] * j * used[i]->difference_px;
    }
    // All samples at one disparity leave the scale undetermined: the offset alone.
    const Eigen::Vector2d next = std::fabs(A.determinant()) > 1e-9 * A(0, 0) * A(1, 1)
                                     ? Eigen::Vector2d(A.ldlt().solve(b))
                                     : Eigen::Vector2d(b(0) / A(0, 0), 0.0);
    for (size_t i = 0; i < used.size(); ++i)
      abs_e[i] = std::fabs(used[i]->difference_px - next(0) - next(1) * used[i]->lidar_px);
    fit.sigma_px = std::max(1.4826 * medianOf(abs_e), 1e-6);
    const double k = 1.345 * fit.sigma_px;
    for (size_t i = 0; i < used.size(); ++i) w[i] = abs_e[i] <= k ? 1.0 : k / abs_e[i];
    const bool settled = (next - x).cwiseAbs().maxCoeff() < 1e-9;
    x = next;
    if (settled) break;
  }
  fit.offset_px = x(0);
  fit.scale = x(1);
  return fit;
}

DisparitySignatures disparitySignatures(const std::vector<DisparitySample>& samples) {
  DisparitySignatures out;
  std::array<std::vector<double>, DisparitySignatures::kThirds> thirds;
  for (const DisparitySample& s : samples) {
    if (!kept(s)) continue;
    ++out.points;
    const int t = std::clamp(static_cast<int>(std::floor(s.column_fraction * 3.0)), 0, 2);
    thirds[t].push_back(s.difference_px);
  }
  for (int t = 0; t < DisparitySignatures::kThirds; ++t) {
    out.third_points[t] = static_cast<int>(thirds[t].size());
    out.third_median_px[t] = medianOf(thirds[t]);
  }
  ringSignature(samples, &out);
  out.fit = fitDisparityOffsetAndScale(samples);
  return out;
}

}  // namespace tescalib
