// LiDAR triangle mesh from the scan's rings (paper, "Data Preprocessing"): a range image whose rows
// are the rings and whose columns are azimuth bins; neighbouring returns of adjacent rings and
// azimuths form two triangles per cell. Triangles across depth discontinuities or seen at grazing
// angles are rejected.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "tescalib/core/common/types.h"

namespace tescalib {

struct LidarMeshSettings {
  /// Max columns of the range image (HDL-64E: ~2000 per turn); fewer when the densest ring has
  /// fewer returns per turn (a scan cropped to a sector, under 5/6 of the turn, counts its
  /// returns as if the ring went all the way round at their spacing).
  int azimuth_bins = 2000;
  double max_range = 80.0;  ///< m; farther returns are not meshed
  double min_range = 2.0;   ///< m; closer returns (the vehicle itself) are ignored
  /// Reject when any edge is longer than this times range, unless its rays are so far apart
  /// that a plane seen at max_incidence_deg makes it longer (sparse LiDARs' ring spacing).
  double max_edge_ratio = 0.06;
  double max_edge_abs = 2.5;        ///< m; and never longer than this
  double max_incidence_deg = 80.0;  ///< reject faces seen at a more grazing angle
  /// Folds (a face spanning the corner between two surfaces, e.g. from the road under a car up
  /// its back) are dropped in scans of fewer rings than this (0: never; counted up to the
  /// highest ring with a return: a 64-ring scan under open sky shows 63). At 16 and 32 rings they
  /// sit 10-35 cm off both surfaces and pull the estimate by 0.05 deg; at 64 they are four times
  /// smaller, and the covariances' model error is calibrated with them, so they stay. (Not by ring
  /// gap: KITTI's HDL-64E has gaps of 0.66 deg, every 2nd ring of the generated one 0.67 deg.)
  int fold_below_rings = 48;
  /// Face normals are fitted (PCA) to the points within +-smooth_cols azimuth bins and rings
  /// -1..+2 that lie near the face's plane, and kept when within `smooth_max_angle_deg` of the
  /// face's own: a single face's normal (a 3-10 cm edge along the ring, 2 cm range noise) is off
  /// by degrees (test LidarMesh.FittedNormalsFollowThePlaneUnderRangeNoise: median 24 deg on a
  /// wall 10 m away and 9 deg on the road, fitted 1.4 and 0.4 deg), which invents constraints
  /// along a plane (on a generated highway the estimate drifted 58 cm along the road with
  /// averaged face normals, 1-3 cm with fitted ones).
  int smooth_cols = 6;
  double smooth_max_angle_deg = 60.0;
  /// Normals are fitted only for a sample (evenly strided, or `consistent_sample`) of at most
  /// this many faces (`LidarMesh::sample`), the faces the solvers draw from (the LiDAR-stereo
  /// solver takes at most 4000 per keyframe); <= 0: every face. Fitting all ~73k faces in view of a
  /// 64-ring scan was most of the mesh's cost. Solvers that want more faces than the sample get the
  /// sample.
  int sampled_faces = 4000;
  /// Draw the sample, and the solvers' faces from it, with `consistentSample` (by each face's
  /// place in the range image) instead of evenly strided over the faces in view. The strided
  /// sample depends on the view cone, i.e. on the initial guess: a cone a degree wider shifts
  /// the stride, other faces are drawn, and the LiDAR-stereo estimate moves by about its
  /// statistical sigma with the guess (doc/limitations.md, "Start dependence"). Off by default: the
  /// covariances' model errors were fitted with the strided sample, and every benchmark figure
  /// moves with the draw.
  bool consistent_sample = false;
  /// Keep only faces whose centroid lies within this half-angle (deg) of `view_axis` (LiDAR
  /// frame); <= 0 keeps everything. Used to keep the part of the scan the cameras can see.
  double view_half_angle_deg = 0.0;
  Eigen::Vector3d view_axis = Eigen::Vector3d::UnitX();
  /// Threads for the normal fits (0: all cores); the mesh does not depend on it.
  int threads = 0;
};

/// One triangle of the mesh, in the LiDAR frame.
struct MeshFace {
  Eigen::Vector3f a, b, c;   ///< vertices
  Eigen::Vector3f centroid;  ///< (a + b + c) / 3
  Eigen::Vector3f normal;    ///< unit normal, oriented towards the sensor
  float range = 0.f;         ///< distance of the centroid from the sensor, m
  /// The face's place in the range image, ring << 16 | (azimuth bin * 2 + triangle): the same
  /// whatever the view cone (the initial guess) let into the mesh. Samples are drawn by it.
  uint32_t key = 0;
};

struct LidarMesh {
  std::vector<MeshFace> faces;
  /// Indices into `faces`, increasing (evenly strided, or consistentSample): the faces whose
  /// normals are fitted (every face when `sampled_faces` <= 0). The other faces keep their own
  /// normal (degrees off under range noise): use them for their vertices, draw normals from the
  /// sample.
  std::vector<uint32_t> sample;
  bool consistent_sample = false;  ///< LidarMeshSettings::consistent_sample it was built with
};

/// min(n, k) indices of [0, n), evenly strided: i * n / k for i < k (every index when n <= k).
std::vector<size_t> evenlyStrided(size_t n, int k);

/// At most k faces of `candidates` (indices into `faces`), as increasing indices, chosen by their
/// keys alone: each ring of the range image is cut into runs of S azimuth positions (S the
/// largest power of two at which at least k runs hold a candidate), each run gives its candidate
/// whose key hashes lowest, and of those the k with the lowest hashes are kept. A stratified
/// random sample: as even as a stride, without a stride's regular pattern, also when the
/// candidates are a sparse sample themselves (a draw from LidarMesh::sample is stratified at a
/// multiple of the sample's S and nests in it). Whether a face is drawn does not depend on the
/// candidates outside its run (unless S or the k-th lowest hash moves), so meshes of one scan
/// built with different view cones (different initial guesses) share their sample where they
/// overlap (an evenly strided sample of the faces in view shifts with the cone).
/// All of them when there are at most k; k <= 0: none.
std::vector<size_t> consistentSample(const std::vector<MeshFace>& faces,
                                     const std::vector<size_t>& candidates, int k);

/// At most k faces of `mesh.sample`, evenly strided (consistentSample of it when the mesh was
/// built with `consistent_sample`): indices into `mesh.faces`.
std::vector<size_t> sampleFaces(const LidarMesh& mesh, int k);

/// Keeps every nth laser ring of `scan` (rings 0, n, 2n, ...), renumbered 0, 1, 2, ...: a sparser
/// LiDAR from the same scan (64 rings with n = 4: 16). n <= 1 leaves the scan as it is.
void keepEveryNthRing(LidarScan* scan, int n);

/// Largest ring count and azimuth resolution buildLidarMesh accepts (its range image is
/// rings x bins): today's LiDARs have at most 128 rings and a few thousand returns per turn.
constexpr int kMaxRings = 512;
constexpr int kMaxAzimuthBins = 16384;

/// Builds the mesh of one scan (points must carry their ring). Throws DataError for settings out
/// of range and for a ring number of kMaxRings or more.
LidarMesh buildLidarMesh(const LidarScan& scan, const LidarMeshSettings& settings = {});

}  // namespace tescalib
