#include "tescalib/core/io/velodyne_bin.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numeric>
#include <vector>

#include "tescalib/core/common/error.h"

namespace tescalib {

LidarScan readVelodyneBin(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw DataError(path + ": cannot open LiDAR scan");
  const std::streamsize bytes = in.tellg();
  if (bytes % 16 != 0)
    throw DataError(path + ": truncated LiDAR scan (" + std::to_string(bytes) +
                    " bytes is not a multiple of 16 = 4 float32 per point)");
  if (bytes == 0) throw DataError(path + ": empty LiDAR scan");
  in.seekg(0);
  std::vector<float> raw(static_cast<size_t>(bytes / 4));
  in.read(reinterpret_cast<char*>(raw.data()), bytes);
  LidarScan scan(raw.size() / 4);
  for (size_t i = 0; i < scan.size(); ++i) {
    scan[i].x = raw[4 * i];
    scan[i].y = raw[4 * i + 1];
    scan[i].z = raw[4 * i + 2];
    scan[i].intensity = raw[4 * i + 3];
  }
  recoverRings(scan);
  return scan;
}

void writeVelodyneBin(const std::string& path, const LidarScan& scan) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw DataError(path + ": cannot write LiDAR scan");
  std::vector<float> raw(scan.size() * 4);
  for (size_t i = 0; i < scan.size(); ++i) {
    raw[4 * i] = scan[i].x;
    raw[4 * i + 1] = scan[i].y;
    raw[4 * i + 2] = scan[i].z;
    raw[4 * i + 3] = scan[i].intensity;
  }
  out.write(reinterpret_cast<const char*>(raw.data()),
            static_cast<std::streamsize>(raw.size() * 4));
}

int recoverRings(LidarScan& scan) {
  if (scan.empty()) return 0;
  // KITTI stores each laser's revolution in turn, starting and ending facing forward (azimuth 0),
  // so a new ring starts where the azimuth crosses 0 in the sweep direction. (The wrap at +-180
  // deg lies inside a ring.) The sweep direction is taken from the data: the median step.
  std::vector<float> az(scan.size());
  for (size_t i = 0; i < scan.size(); ++i) az[i] = std::atan2(scan[i].y, scan[i].x);
  std::vector<float> steps;
  steps.reserve(scan.size() / 8 + 1);
  for (size_t i = 8; i < scan.size(); i += 8) {
    float d = az[i] - az[i - 8];
    if (d > float(M_PI)) d -= float(2 * M_PI);
    if (d < -float(M_PI)) d += float(2 * M_PI);
    steps.push_back(d);
  }
  float direction = 1.f;
  if (!steps.empty()) {
    std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
    direction = steps[steps.size() / 2] < 0 ? -1.f : 1.f;
  }
  constexpr size_t kMinRingPoints = 50;  // jitter around azimuth 0 must not split a ring
  std::vector<size_t> starts{0};
  for (size_t i = 1; i < scan.size(); ++i) {
    const float prev = direction * az[i - 1];
    const float cur = direction * az[i];
    const bool crosses_forward =
        prev < 0.f && prev > -float(M_PI_2) && cur >= 0.f && cur < float(M_PI_2);
    if (crosses_forward && i - starts.back() >= kMinRingPoints) starts.push_back(i);
  }
  starts.push_back(scan.size());
  const int n = static_cast<int>(starts.size()) - 1;
  // Order segments by mean elevation so that ring 0 is the lowest beam.
  std::vector<double> elevation(n, 0.0);
  for (int s = 0; s < n; ++s) {
    double sum = 0;
    for (size_t i = starts[s]; i < starts[s + 1]; ++i) {
      const auto& p = scan[i];
      sum += std::atan2(p.z, std::hypot(p.x, p.y));
    }
    elevation[s] = sum / static_cast<double>(starts[s + 1] - starts[s]);
  }
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return elevation[a] < elevation[b]; });
  std::vector<int> ring_of_segment(n);
  for (int r = 0; r < n; ++r) ring_of_segment[order[r]] = r;
  for (int s = 0; s < n; ++s)
    for (size_t i = starts[s]; i < starts[s + 1]; ++i)
      scan[i].ring = static_cast<uint16_t>(ring_of_segment[s]);
  return n;
}

}  // namespace tescalib
