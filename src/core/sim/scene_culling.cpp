#include "tescalib/core/sim/scene_culling.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "tescalib/core/common/pinhole.h"

namespace tescalib {
namespace sim {
namespace {

constexpr float kTwoPi = 6.283185307179586f;

/// The 12 edges of a box given as corner indices (corner k = iz * 4 + iy * 2 + ix).
constexpr int kEdges[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                               {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};

}  // namespace

TileCandidates::TileCandidates(int tiles_x, int tiles_y)
    : tiles_x_(std::max(tiles_x, 1)), tiles_y_(std::max(tiles_y, 1)) {}

void TileCandidates::add(uint32_t prim, float min_dist, int tx0, int tx1, int ty0, int ty1) {
  tx0 = std::max(tx0, 0), ty0 = std::max(ty0, 0);
  tx1 = std::min(tx1, tiles_x_ - 1), ty1 = std::min(ty1, tiles_y_ - 1);
  for (int ty = ty0; ty <= ty1; ++ty)
    for (int tx = tx0; tx <= tx1; ++tx)
      pending_.push_back({static_cast<uint32_t>(index(tx, ty)), {prim, min_dist}});
}

void TileCandidates::finalize() {
  const size_t bins = static_cast<size_t>(tiles_x_) * tiles_y_;
  offsets_.assign(bins + 1, 0);
  for (const auto& p : pending_) ++offsets_[p.bin + 1];
  for (size_t b = 0; b < bins; ++b) offsets_[b + 1] += offsets_[b];
  items_.resize(pending_.size());
  std::vector<uint32_t> fill(offsets_.begin(), offsets_.end() - 1);
  for (const auto& p : pending_) items_[fill[p.bin]++] = p.c;
  for (size_t b = 0; b < bins; ++b)
    std::sort(items_.begin() + offsets_[b], items_.begin() + offsets_[b + 1],
              [](const Candidate& a, const Candidate& c) {
                return a.min_dist < c.min_dist || (a.min_dist == c.min_dist && a.prim < c.prim);
              });
  pending_.clear();
  pending_.shrink_to_fit();
}

TileCandidates cullPinhole(const std::vector<Primitive>& prims, const PinholeView& view,
                           float max_range, int tile) {
  const int ntx = (view.width + tile - 1) / tile, nty = (view.height + tile - 1) / tile;
  TileCandidates out(ntx, nty);
  constexpr float kNear = 0.05f;
  Eigen::Vector3f corners[8], cam[8];
  for (uint32_t i = 0; i < prims.size(); ++i) {
    const float d = distanceToBounds(prims[i], view.origin);
    if (d > max_range) continue;
    if (d <= 0.f) {
      out.add(i, 0.f, 0, ntx - 1, 0, nty - 1);
      continue;
    }
    boundsCorners(prims[i], corners);
    for (int k = 0; k < 8; ++k) cam[k] = view.R_cam_world * (corners[k] - view.origin);
    float umin = std::numeric_limits<float>::max(), umax = -umin, vmin = umin, vmax = -umin;
    bool any = false;
    auto project = [&](const Eigen::Vector3f& c) {
      const Eigen::Vector2f px = projectPinhole(view.fx, view.fy, view.cx, view.cy, c);
      const float u = px.x(), v = px.y();
      umin = std::min(umin, u), umax = std::max(umax, u);
      vmin = std::min(vmin, v), vmax = std::max(vmax, v);
      any = true;
    };
    for (int k = 0; k < 8; ++k)
      if (cam[k].z() >= kNear) project(cam[k]);
    for (const auto& e : kEdges) {  // clip the box edges at the near plane
      const Eigen::Vector3f &a = cam[e[0]], &b = cam[e[1]];
      if ((a.z() < kNear) != (b.z() < kNear)) {
        const float f = (kNear - a.z()) / (b.z() - a.z());
        project(a + f * (b - a));
      }
    }
    if (!any || umax < -1.f || vmax < -1.f || umin > view.width || vmin > view.height) continue;
    const auto tileOf = [tile](float x) {
      return static_cast<int>(std::floor(std::clamp(x, -1e6f, 1e6f) / tile));
    };
    out.add(i, d, tileOf(umin - 1.5f), tileOf(umax + 1.5f), tileOf(vmin - 1.5f),
            tileOf(vmax + 1.5f));
  }
  out.finalize();
  return out;
}

int azimuthBin(const Eigen::Vector3f& dir, int bins) {
  float az = std::atan2(dir.y(), dir.x());
  if (az < 0.f) az += kTwoPi;
  return std::min(static_cast<int>(az / kTwoPi * bins), bins - 1);
}

TileCandidates cullSpinning(const std::vector<Primitive>& prims,
                            const Eigen::Matrix3f& R_sensor_world, const Eigen::Vector3f& origin,
                            float max_range, int bins) {
  TileCandidates out(bins, 1);
  Eigen::Vector3f corners[8];
  for (uint32_t i = 0; i < prims.size(); ++i) {
    const float d = distanceToBounds(prims[i], origin);
    if (d > max_range) continue;
    boundsCorners(prims[i], corners);
    Eigen::Vector3f centre = Eigen::Vector3f::Zero();
    Eigen::Vector3f local[8];
    for (int k = 0; k < 8; ++k) {
      local[k] = R_sensor_world * (corners[k] - origin);
      centre += local[k] / 8.f;
    }
    const float az_c = std::atan2(centre.y(), centre.x());
    float lo = 0.f, hi = 0.f;
    for (int k = 0; k < 8; ++k) {
      float delta = std::atan2(local[k].y(), local[k].x()) - az_c;
      if (delta > float(M_PI)) delta -= kTwoPi;
      if (delta < -float(M_PI)) delta += kTwoPi;
      lo = std::min(lo, delta), hi = std::max(hi, delta);
    }
    // Spanning more than a half turn means the sensor's axis may pass through the box.
    if (d < 0.5f || hi - lo > 0.9f * float(M_PI)) {
      out.add(i, d, 0, bins - 1, 0, 0);
      continue;
    }
    const float scale = bins / kTwoPi;
    const int b0 = static_cast<int>(std::floor((az_c + lo) * scale)) - 1;
    const int b1 = static_cast<int>(std::floor((az_c + hi) * scale)) + 1;
    for (int b = b0; b <= b1; ++b) {
      const int w = ((b % bins) + bins) % bins;
      out.add(i, d, w, w, 0, 0);
    }
  }
  out.finalize();
  return out;
}

TraceResult traceRay(const std::vector<Primitive>& prims, const Candidate* begin,
                     const Candidate* end, const Eigen::Vector3f& o, const Eigen::Vector3f& d,
                     float tmax) {
  TraceResult r;
  r.t = tmax;
  if (d.z() < 0.f && o.z() > 0.f) {
    const float tg = -o.z() / d.z();
    if (tg < tmax) {
      r.t = tg;
      r.prim = TraceResult::kGround;
    }
  }
  PrimitiveHit h;
  for (const Candidate* c = begin; c != end; ++c) {
    if (c->min_dist >= r.t) break;
    if (intersectPrimitive(prims[c->prim], o, d, 1e-4f, r.t, &h)) {
      r.t = h.t;
      r.prim = static_cast<int>(c->prim);
      r.hit = h;
    }
  }
  return r;
}

SunShadowGrid::SunShadowGrid(const std::vector<Primitive>& prims, const Eigen::Vector3f& sun,
                             const Eigen::Vector3f& centre, float radius, float cell)
    : prims_(&prims), sun_(sun.normalized()), cell_(cell) {
  e1_ = sun_.cross(Eigen::Vector3f::UnitZ());
  if (e1_.norm() < 1e-3f) e1_ = Eigen::Vector3f::UnitX();
  e1_.normalize();
  e2_ = sun_.cross(e1_).normalized();
  struct Box {
    uint32_t prim;         ///< primitive index
    float a0, a1, b0, b1;  ///< extent across the sun direction (m)
    float top;             ///< highest point along the sun direction (m)
  };
  std::vector<Box> boxes;
  Eigen::Vector3f corners[8];
  const float ac = centre.dot(e1_), bc = centre.dot(e2_);
  const float reach = 1.5f * radius;
  for (uint32_t i = 0; i < prims.size(); ++i) {
    if (distanceToBounds(prims[i], centre) > radius) continue;
    boundsCorners(prims[i], corners);
    Box b{i, 1e30f, -1e30f, 1e30f, -1e30f, -1e30f};
    for (const auto& c : corners) {
      const float a = c.dot(e1_), bb = c.dot(e2_);
      b.a0 = std::min(b.a0, a), b.a1 = std::max(b.a1, a);
      b.b0 = std::min(b.b0, bb), b.b1 = std::max(b.b1, bb);
      b.top = std::max(b.top, c.dot(sun_));
    }
    b.a0 = std::max(b.a0, ac - reach), b.a1 = std::min(b.a1, ac + reach);
    b.b0 = std::max(b.b0, bc - reach), b.b1 = std::min(b.b1, bc + reach);
    if (b.a0 <= b.a1 && b.b0 <= b.b1) boxes.push_back(b);
  }
  a0_ = ac - reach, b0_ = bc - reach;
  w_ = h_ = static_cast<int>(std::ceil(2.f * reach / cell_)) + 1;
  offsets_.assign(static_cast<size_t>(w_) * h_ + 1, 0);
  auto cellRange = [&](const Box& b, int* x0, int* x1, int* y0, int* y1) {
    *x0 = std::clamp(static_cast<int>((b.a0 - a0_) / cell_), 0, w_ - 1);
    *x1 = std::clamp(static_cast<int>((b.a1 - a0_) / cell_), 0, w_ - 1);
    *y0 = std::clamp(static_cast<int>((b.b0 - b0_) / cell_), 0, h_ - 1);
    *y1 = std::clamp(static_cast<int>((b.b1 - b0_) / cell_), 0, h_ - 1);
  };
  int x0, x1, y0, y1;
  for (const auto& b : boxes) {
    cellRange(b, &x0, &x1, &y0, &y1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) ++offsets_[static_cast<size_t>(y) * w_ + x + 1];
  }
  for (size_t k = 1; k < offsets_.size(); ++k) offsets_[k] += offsets_[k - 1];
  items_.resize(offsets_.back());
  item_top_.resize(offsets_.back());
  std::vector<uint32_t> fill(offsets_.begin(), offsets_.end() - 1);
  for (const auto& b : boxes) {
    cellRange(b, &x0, &x1, &y0, &y1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const uint32_t k = fill[static_cast<size_t>(y) * w_ + x]++;
        items_[k] = b.prim;
        item_top_[k] = b.top;
      }
  }
}

bool SunShadowGrid::sunlit(const Eigen::Vector3f& p) const {
  const float a = p.dot(e1_) - a0_, b = p.dot(e2_) - b0_;
  if (a < 0.f || b < 0.f) return true;
  const int x = static_cast<int>(a / cell_), y = static_cast<int>(b / cell_);
  if (x >= w_ || y >= h_) return true;
  const size_t c = static_cast<size_t>(y) * w_ + x;
  const float h = p.dot(sun_);
  PrimitiveHit hit;
  for (uint32_t k = offsets_[c]; k < offsets_[c + 1]; ++k) {
    if (item_top_[k] <= h) continue;
    if (intersectPrimitive((*prims_)[items_[k]], p, sun_, 0.f, 1e30f, &hit)) return false;
  }
  return true;
}

}  // namespace sim
}  // namespace tescalib
