// The range image of a LiDAR scan (paper, "Data Preprocessing"): its rows are the laser rings,
// its columns azimuth bins over the whole turn, and each cell holds the scan's closest return in
// it. Neighbouring cells are neighbouring returns: the LiDAR mesh's triangles and the
// neighbourhoods of its normal fits.
#pragma once

#include <cstddef>
#include <vector>

#include "tescalib/core/common/types.h"

namespace tescalib {

struct RangeImage {
  int rings = 0;
  int cols = 0;
  std::vector<int> cells;  ///< ring-major: the scan index of each cell's return, -1 for none

  /// The return at (ring, col), the column wrapping around the turn; -1 when there is none.
  int at(int ring, int col) const {
    return cells[static_cast<size_t>(ring) * cols + ((col % cols) + cols) % cols];
  }
};

/// The range image of `scan` (rings numbered below `rings`) with at most `max_cols` azimuth bins
/// (at least 16), no finer than the densest ring's returns per turn: neighbours must be adjacent
/// bins. Returns beyond [min_range, max_range] and non-finite ones are left out.
RangeImage buildRangeImage(const LidarScan& scan, int rings, int max_cols, double min_range,
                           double max_range);

}  // namespace tescalib
