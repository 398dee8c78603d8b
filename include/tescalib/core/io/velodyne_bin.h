// KITTI's LiDAR scan files (ROS-free): float32 x y z reflectance per point, one laser's
// revolution after the other, which is how the laser index of each point is recovered.
#pragma once

#include <string>

#include "tescalib/core/common/types.h"

namespace tescalib {

/// Reads a KITTI velodyne .bin (float32 x y z reflectance). Throws DataError on a missing or
/// truncated file. Rings are recovered with recoverRings().
LidarScan readVelodyneBin(const std::string& path);

/// Writes a KITTI velodyne .bin (ring is not stored; the reader recovers it from scan order).
void writeVelodyneBin(const std::string& path, const LidarScan& scan);

/// Recovers the laser index of every point of a KITTI scan stored in sensor order: the scan is
/// ring after ring (top beam first), each ring one revolution, so a new ring starts where the
/// azimuth wraps around. Rings are numbered 0 = lowest beam. Returns the number of rings found.
int recoverRings(LidarScan& scan);

}  // namespace tescalib
