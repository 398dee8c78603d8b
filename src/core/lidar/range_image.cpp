#include "tescalib/core/lidar/range_image.h"

#include <algorithm>
#include <cmath>

namespace tescalib {
namespace {

/// The returns per turn of the densest ring. The bins span the whole turn; a scan its driver
/// cropped to a sector (a camera's view) has that many returns in the sector only: counted over
/// the turn, its bins would be several beams wide and keep one return in three. Scaled up by the
/// densest ring's coverage when it covers less than 5/6 of the turn (a full turn with a few gaps
/// is taken as it is).
double densestRingPerTurn(const LidarScan& scan, int rings) {
  std::vector<int> per_ring(rings, 0);
  for (const auto& p : scan) ++per_ring[p.ring];
  const int densest =
      static_cast<int>(std::max_element(per_ring.begin(), per_ring.end()) - per_ring.begin());
  double per_turn = per_ring[densest];
  std::vector<double> az;
  az.reserve(per_ring[densest]);
  for (const auto& p : scan)
    if (p.ring == densest && std::isfinite(p.x) && std::isfinite(p.y))
      az.push_back(std::atan2(p.y, p.x));
  if (az.size() >= 2) {
    std::sort(az.begin(), az.end());
    double gap = az.front() + 2 * M_PI - az.back();
    for (size_t i = 1; i < az.size(); ++i) gap = std::max(gap, az[i] - az[i - 1]);
    const double coverage = (2 * M_PI - gap) / (2 * M_PI);
    if (coverage > 0 && coverage < 5.0 / 6.0) per_turn = az.size() / coverage;
  }
  return per_turn;
}

}  // namespace

RangeImage buildRangeImage(const LidarScan& scan, int rings, int max_cols, double min_range,
                           double max_range) {
  RangeImage image;
  image.rings = rings;
  const double per_turn = densestRingPerTurn(scan, rings);
  const int cols = std::max(16, static_cast<int>(std::min<double>(max_cols, std::floor(per_turn))));
  image.cols = cols;
  // The closest return per (ring, azimuth bin).
  std::vector<int>& grid = image.cells;
  grid.assign(static_cast<size_t>(rings) * cols, -1);
  std::vector<float> grid_range(grid.size(), 0.f);
  for (size_t i = 0; i < scan.size(); ++i) {
    const auto& p = scan[i];
    const float r = std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z);
    if (!std::isfinite(r) || r < min_range || r > max_range) continue;
    const double az = std::atan2(p.y, p.x);
    int c = static_cast<int>(std::floor((az + M_PI) / (2 * M_PI) * cols));
    c = std::min(std::max(c, 0), cols - 1);
    const size_t k = static_cast<size_t>(p.ring) * cols + c;
    if (grid[k] < 0 || r < grid_range[k]) grid[k] = static_cast<int>(i), grid_range[k] = r;
  }
  return image;
}

}  // namespace tescalib
