#include "tescalib/core/sim/scene_road.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace tescalib {
namespace sim {

double RoadCurves::heading(double s) const {
  double h = 0;
  for (int k = 0; k < 2; ++k) h += amplitude[k] * std::sin(2 * M_PI * s / length[k] + phase[k]);
  return h;
}

double RoadCurves::curvature(double s) const {
  double c = 0;
  for (int k = 0; k < 2; ++k)
    c += amplitude[k] * (2 * M_PI / length[k]) * std::cos(2 * M_PI * s / length[k] + phase[k]);
  return c;
}

RoadPath::RoadPath(const RoadCurves& curves, double s_min, double s_max, double corridor)
    : curves_(curves), step_(0.5), corridor_(static_cast<float>(corridor)) {
  s_min_ = std::floor(s_min / step_) * step_;
  s_max_ = std::max(s_min_ + step_, std::ceil(s_max / step_) * step_);
  const int n = static_cast<int>(std::lround((s_max_ - s_min_) / step_)) + 1;
  points_.resize(n);
  // Station 0 sits at the world origin; integrate the heading forwards and backwards from it.
  const int i0 = std::clamp(static_cast<int>(std::lround(-s_min_ / step_)), 0, n - 1);
  Eigen::Vector2d p = Eigen::Vector2d::Zero();
  if (s_min_ + i0 * step_ != 0.0) {
    // Station 0 outside the sampled range: integrate up to the first sample.
    const double s_start = s_min_ + i0 * step_;
    const int m = static_cast<int>(std::ceil(std::fabs(s_start) / step_));
    const double h = s_start / m;
    for (int k = 0; k < m; ++k) {
      const double th = curves_.heading((k + 0.5) * h);
      p += h * Eigen::Vector2d(std::cos(th), std::sin(th));
    }
  }
  points_[i0] = p;
  for (int i = i0 + 1; i < n; ++i) {
    const double th = curves_.heading(s_min_ + (i - 0.5) * step_);
    points_[i] = points_[i - 1] + step_ * Eigen::Vector2d(std::cos(th), std::sin(th));
  }
  for (int i = i0 - 1; i >= 0; --i) {
    const double th = curves_.heading(s_min_ + (i + 0.5) * step_);
    points_[i] = points_[i + 1] - step_ * Eigen::Vector2d(std::cos(th), std::sin(th));
  }
  tangents_.resize(n);
  for (int i = 0; i < n; ++i) {
    const double th = curves_.heading(s_min_ + i * step_);
    tangents_[i] =
        Eigen::Vector2f(static_cast<float>(std::cos(th)), static_cast<float>(std::sin(th)));
  }

  // Lookup grid: stamp every sample along its normal; each cell keeps the sample it is closest
  // to laterally. With curvature radii of hundreds of metres the normals never cross within the
  // corridor, so that sample is within a few samples of the true foot point.
  Eigen::Vector2d lo = points_[0], hi = points_[0];
  for (const auto& q : points_) {
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  grid_x0_ = lo.x() - corridor - cell_;
  grid_y0_ = lo.y() - corridor - cell_;
  grid_w_ = static_cast<int>(std::ceil((hi.x() - lo.x() + 2 * corridor) / cell_)) + 3;
  grid_h_ = static_cast<int>(std::ceil((hi.y() - lo.y() + 2 * corridor) / cell_)) + 3;
  grid_.assign(static_cast<size_t>(grid_w_) * grid_h_, -1);
  std::vector<float> best(grid_.size(), std::numeric_limits<float>::max());
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d normal(-tangents_[i].y(), tangents_[i].x());
    for (double l = -corridor; l <= corridor; l += 0.5) {
      const Eigen::Vector2d q = points_[i] + l * normal;
      const int cx = static_cast<int>((q.x() - grid_x0_) / cell_);
      const int cy = static_cast<int>((q.y() - grid_y0_) / cell_);
      if (cx < 0 || cy < 0 || cx >= grid_w_ || cy >= grid_h_) continue;
      const size_t c = static_cast<size_t>(cy) * grid_w_ + cx;
      if (std::fabs(l) < best[c]) {
        best[c] = static_cast<float>(std::fabs(l));
        grid_[c] = i;
      }
    }
  }
}

Eigen::Vector2d RoadPath::point(double s) const {
  const double x = std::clamp((s - s_min_) / step_, 0.0, double(points_.size() - 1));
  const int i = std::min(static_cast<int>(x), static_cast<int>(points_.size()) - 2);
  const double f = x - i;
  return (1 - f) * points_[i] + f * points_[i + 1];
}

Eigen::Vector2d RoadPath::toWorld(double s, double l) const {
  const double th = heading(s);
  return point(s) + l * Eigen::Vector2d(-std::sin(th), std::cos(th));
}

bool RoadPath::toRoad(float x, float y, float* s, float* l, Eigen::Vector2f* tangent) const {
  const int cx = static_cast<int>((x - grid_x0_) / cell_);
  const int cy = static_cast<int>((y - grid_y0_) / cell_);
  if (x < grid_x0_ || y < grid_y0_ || cx >= grid_w_ || cy >= grid_h_) return false;
  const int hint = grid_[static_cast<size_t>(cy) * grid_w_ + cx];
  if (hint < 0) return false;
  const int n = static_cast<int>(points_.size());
  const int j0 = std::max(hint - 5, 0), j1 = std::min(hint + 5, n - 2);
  float best_d2 = std::numeric_limits<float>::max();
  int best_j = hint;
  float best_tau = 0.f;
  for (int j = j0; j <= j1; ++j) {
    const float px = x - static_cast<float>(points_[j].x());
    const float py = y - static_cast<float>(points_[j].y());
    const float ex = static_cast<float>(points_[j + 1].x() - points_[j].x());
    const float ey = static_cast<float>(points_[j + 1].y() - points_[j].y());
    const float tau = std::clamp((px * ex + py * ey) / (ex * ex + ey * ey), 0.f, 1.f);
    const float dx = px - tau * ex, dy = py - tau * ey;
    const float d2 = dx * dx + dy * dy;
    if (d2 < best_d2) best_d2 = d2, best_j = j, best_tau = tau;
  }
  const Eigen::Vector2f t =
      ((1.f - best_tau) * tangents_[best_j] + best_tau * tangents_[best_j + 1]).normalized();
  const float px = x - static_cast<float>(points_[best_j].x());
  const float py = y - static_cast<float>(points_[best_j].y());
  *l = t.x() * py - t.y() * px;
  if (std::fabs(*l) > corridor_) return false;
  *s = static_cast<float>(s_min_ + (best_j + best_tau) * step_);
  if (tangent) *tangent = t;
  return true;
}

}  // namespace sim
}  // namespace tescalib
