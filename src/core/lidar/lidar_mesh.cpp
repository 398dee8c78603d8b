#include "tescalib/core/lidar/lidar_mesh.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "tescalib/core/common/error.h"
#include "tescalib/core/common/parallel.h"
#include "tescalib/core/lidar/range_image.h"

namespace tescalib {

std::vector<size_t> evenlyStrided(size_t n, int k) {
  std::vector<size_t> idx;
  if (k <= 0) return idx;
  const size_t m = std::min(n, static_cast<size_t>(k));
  idx.reserve(m);
  for (size_t i = 0; i < m; ++i) idx.push_back(i * n / m);
  return idx;
}

namespace {
/// splitmix64's finaliser: a well-mixed 64-bit hash of a face key.
uint64_t mixKey(uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

/// The run of s azimuth positions a face key (ring << 16 | position) falls in.
uint32_t runOf(uint32_t key, uint32_t s) { return (key >> 16) << 16 | (key & 0xFFFFu) / s; }
}  // namespace

std::vector<size_t> consistentSample(const std::vector<MeshFace>& faces,
                                     const std::vector<size_t>& candidates, int k) {
  if (k <= 0) return {};
  if (candidates.size() <= static_cast<size_t>(k)) return candidates;
  // Stratified: the range image's rings cut into runs of S azimuth positions (S a power of two,
  // the largest at which at least k runs hold a candidate), from each run the face whose key
  // hashes lowest (as even as a stride over dense candidates, without a stride's regular
  // pattern), and of those the k lowest. S is set by the runs that hold candidates, not by their
  // number: candidates that are themselves a sample (sampleFaces draws from LidarMesh::sample,
  // one face per run of the mesh's S) are stratified at a multiple of that S, and a run's lowest
  // hash is the lowest of its halves' lowest, so the draw nests in the sample.
  std::vector<uint32_t> keys;
  keys.reserve(candidates.size());
  for (size_t i : candidates) keys.push_back(faces[i].key);
  std::sort(keys.begin(), keys.end());
  const auto runsAt = [&keys](uint32_t s) {
    size_t runs = 0;
    uint32_t last = 0;
    for (size_t j = 0; j < keys.size(); ++j) {
      const uint32_t run = runOf(keys[j], s);
      if (j == 0 || run != last) ++runs;
      last = run;
    }
    return runs;
  };
  uint32_t S = 1;
  while (S < (1u << 16) && runsAt(2 * S) >= static_cast<size_t>(k)) S *= 2;
  struct Drawn {
    uint32_t run;
    uint64_t hash;
    size_t face;
  };
  std::vector<Drawn> drawn;
  drawn.reserve(candidates.size());
  for (size_t i : candidates) {
    const uint32_t key = faces[i].key;
    drawn.push_back({runOf(key, S), mixKey(key), i});
  }
  std::sort(drawn.begin(), drawn.end(), [](const Drawn& x, const Drawn& y) {
    return x.run != y.run ? x.run < y.run : x.hash < y.hash;
  });
  std::vector<std::pair<uint64_t, size_t>> ranked;
  for (size_t j = 0; j < drawn.size(); ++j)
    if (j == 0 || drawn[j].run != drawn[j - 1].run)
      ranked.emplace_back(drawn[j].hash, drawn[j].face);
  std::vector<size_t> idx;
  const size_t n = std::min(ranked.size(), static_cast<size_t>(k));
  std::nth_element(ranked.begin(), ranked.begin() + n, ranked.end());
  idx.reserve(n);
  for (size_t j = 0; j < n; ++j) idx.push_back(ranked[j].second);
  std::sort(idx.begin(), idx.end());
  return idx;
}

std::vector<size_t> sampleFaces(const LidarMesh& mesh, int k) {
  if (mesh.consistent_sample)
    return consistentSample(mesh.faces, std::vector<size_t>(mesh.sample.begin(), mesh.sample.end()),
                            k);
  std::vector<size_t> idx = evenlyStrided(mesh.sample.size(), k);
  for (size_t& i : idx) i = mesh.sample[i];
  return idx;
}

void keepEveryNthRing(LidarScan* scan, int n) {
  if (n <= 1) return;
  scan->erase(std::remove_if(scan->begin(), scan->end(),
                             [n](const LidarPoint& p) { return p.ring % n != 0; }),
              scan->end());
  for (LidarPoint& p : *scan) p.ring = static_cast<uint16_t>(p.ring / n);
}

namespace {

/// A scan point as a vector.
Eigen::Vector3f pointOf(const LidarScan& scan, int i) {
  return Eigen::Vector3f(scan[i].x, scan[i].y, scan[i].z);
}

/// How far a point at `range` may be from a surface that it continues: 3 cm + 0.3 %.
float continueTol(float range) { return 0.03f + 0.003f * range; }

/// The faces of the range image: two triangles per cell of adjacent rings and azimuth bins,
/// rejected across depth discontinuities (edge lengths), at grazing angles, outside the view cone
/// and, in sparse scans, where they fold over the corner between two surfaces.
class Triangulation {
 public:
  Triangulation(const LidarScan& scan, const RangeImage& image, const LidarMeshSettings& s)
      : scan_(scan),
        image_(image),
        s_(s),
        cos_max_inc_(std::cos(s.max_incidence_deg * M_PI / 180.0)),
        cos_view_(std::cos(s.view_half_angle_deg * M_PI / 180.0)),
        axis_(s.view_axis.normalized().cast<float>()),
        folds_(image.rings < s.fold_below_rings) {}

  /// Appends the faces to `mesh` and each one's cell (ring * cols + col) to `face_cell`.
  void run(LidarMesh* mesh, std::vector<int>* face_cell);

 private:
  /// The rings below and above a cell's pair, and whether they continue its points' lines.
  struct CellContext {
    int cell = 0;
    int beyond_lo = -1, beyond_hi = -1;
    bool continues_lo = false, continues_hi = false;  ///< this cell's fold evidence
  };

  CellContext contextOf(int r, int col, int p00, int p01, int p10) const;
  /// Is point k within continueTol of the line through points i and j?
  bool onLine(int i, int j, int k) const;
  bool inViewCone(const Eigen::Vector3f& centroid, float range) const;
  bool edgeTooLong(const Eigen::Vector3f& p, const Eigen::Vector3f& q, float range,
                   bool* sparse) const;
  bool foldOrBridge(const CellContext& cell, const Eigen::Vector3f& n,
                    const Eigen::Vector3f& centroid, float range, bool sparse) const;
  void tryFace(const CellContext& cell, int ia, int ib, int ic, uint32_t triangle);

  const LidarScan& scan_;
  const RangeImage& image_;
  const LidarMeshSettings& s_;
  const double cos_max_inc_, cos_view_;
  const Eigen::Vector3f axis_;
  const bool folds_;  ///< folds only in scans of fewer rings than fold_below_rings
  LidarMesh* mesh_ = nullptr;
  std::vector<int>* face_cell_ = nullptr;
};

void Triangulation::run(LidarMesh* mesh, std::vector<int>* face_cell) {
  mesh_ = mesh, face_cell_ = face_cell;
  const RangeImage& im = image_;
  for (int r = 0; r + 1 < im.rings; ++r) {
    for (int col = 0; col < im.cols; ++col) {
      int p00 = im.at(r, col), p01 = im.at(r, col + 1), p10 = im.at(r + 1, col),
          p11 = im.at(r + 1, col + 1);
      // Bridge one missing bin along the ring (bins are slightly finer than the beam spacing).
      if (p01 < 0) p01 = im.at(r, col + 2);
      if (p11 < 0) p11 = im.at(r + 1, col + 2);
      const CellContext cell = contextOf(r, col, p00, p01, p10);
      tryFace(cell, p00, p01, p10, 0);
      tryFace(cell, p01, p11, p10, 1);
    }
  }
}

Triangulation::CellContext Triangulation::contextOf(int r, int col, int p00, int p01,
                                                    int p10) const {
  const RangeImage& im = image_;
  CellContext cell;
  cell.cell = r * im.cols + col;
  // The rings below and above the face's pair, at its columns (the faces' plane check).
  cell.beyond_lo = r > 0 ? im.at(r - 1, col) : -1;
  if (cell.beyond_lo < 0 && r > 0) cell.beyond_lo = im.at(r - 1, col + 1);
  cell.beyond_hi = r + 2 < im.rings ? im.at(r + 2, col + 1) : -1;
  if (cell.beyond_hi < 0 && r + 2 < im.rings) cell.beyond_hi = im.at(r + 2, col);
  // Where folds are looked for: does the ring-r point of this column (the next column's where
  // it has none: the second triangle's) continue the line of rings r-2, r-1 (ring r+1's that of
  // rings r+3, r+2)? Points of one plane at one azimuth lie on a line.
  const int lo = p00 >= 0 ? p00 : p01;
  cell.continues_lo = folds_ && r > 1 && onLine(im.at(r - 2, col), im.at(r - 1, col), lo);
  cell.continues_hi =
      folds_ && r + 3 < im.rings && onLine(im.at(r + 3, col), im.at(r + 2, col), p10);
  return cell;
}

bool Triangulation::onLine(int i, int j, int k) const {
  if (i < 0 || j < 0 || k < 0) return false;
  const Eigen::Vector3f p = pointOf(scan_, i), d = pointOf(scan_, j) - p, q = pointOf(scan_, k);
  const float len = d.norm();
  if (len < 1e-6f) return false;
  return d.cross(q - p).norm() / len <= continueTol(q.norm());
}

bool Triangulation::inViewCone(const Eigen::Vector3f& centroid, float range) const {
  return !(s_.view_half_angle_deg > 0 && centroid.dot(axis_) < cos_view_ * range);
}

// An edge is at most max_edge_ratio * range, or, between rays further apart than that allows
// (sparse rings: 16 rings 2 deg apart put the road's rings 1-2 m apart at 10 m), as long as a
// plane seen at the grazing limit makes it: range * angle / cos(max incidence). Longer edges span
// a depth discontinuity. `sparse`: set when the edge is longer than max_edge_ratio allows.
bool Triangulation::edgeTooLong(const Eigen::Vector3f& p, const Eigen::Vector3f& q, float range,
                                bool* sparse) const {
  const float ratio = static_cast<float>(s_.max_edge_ratio);
  const float per_rad = static_cast<float>(1.0 / std::max(cos_max_inc_, 1e-3));
  const float sin_angle = p.normalized().cross(q.normalized()).norm();
  const float length = (p - q).norm();
  *sparse = *sparse || length > ratio * range;
  return length > std::min<float>(s_.max_edge_abs, range * std::max(ratio, per_rad * sin_angle));
}

// Do the rings below and above the face's pair continue its plane (within continueTol)?
bool Triangulation::foldOrBridge(const CellContext& cell, const Eigen::Vector3f& n,
                                 const Eigen::Vector3f& centroid, float range, bool sparse) const {
  const bool fold_candidate = cell.continues_lo || cell.continues_hi;
  if (!sparse && !fold_candidate) return false;
  const float tol = continueTol(range);
  int checked = 0, agree = 0;
  for (int i : {cell.beyond_lo, cell.beyond_hi}) {
    if (i < 0) continue;
    ++checked;
    if (std::fabs(n.dot(pointOf(scan_, i) - centroid)) <= tol) ++agree;
  }
  // A face that neither continues is a fold when one of its rings belongs to the surface beyond
  // it: it spans the corner between two surfaces (the road under a car and the car's back, a
  // car's back and its roof), 10-35 cm off both at 16 rings. A surface that only this ring pair
  // sees (a car's back between the road and a wall) has neither and stays.
  if (fold_candidate && checked == 2 && agree == 0) return true;
  // So long a face may bridge two surfaces (the road and a kerb, a car's underside): keep it
  // only when the rings on both sides of it continue its plane, or the one side that has a
  // return there (the lowest ring pair, the sky above).
  return sparse && (checked == 0 || agree < checked);
}

void Triangulation::tryFace(const CellContext& cell, int ia, int ib, int ic, uint32_t triangle) {
  if (ia < 0 || ib < 0 || ic < 0) return;
  const Eigen::Vector3f a = pointOf(scan_, ia), b = pointOf(scan_, ib), c = pointOf(scan_, ic);
  const Eigen::Vector3f centroid = (a + b + c) / 3.f;
  const float range = centroid.norm();
  if (!inViewCone(centroid, range)) return;
  bool sparse = false;
  if (edgeTooLong(a, b, range, &sparse) || edgeTooLong(b, c, range, &sparse) ||
      edgeTooLong(c, a, range, &sparse))
    return;
  Eigen::Vector3f n = (b - a).cross(c - a);
  const float len = n.norm();
  if (len < 1e-9f) return;
  n /= len;
  const Eigen::Vector3f view = centroid / range;
  float cos_inc = n.dot(view);
  if (cos_inc > 0) n = -n, cos_inc = -cos_inc;  // orient towards the sensor
  if (-cos_inc < cos_max_inc_) return;          // grazing
  if (foldOrBridge(cell, n, centroid, range, sparse)) return;
  // The face's key (MeshFace::key): ring, then azimuth bin and triangle.
  const uint32_t key = (static_cast<uint32_t>(cell.cell / image_.cols) << 16) |
                       (static_cast<uint32_t>(cell.cell % image_.cols) * 2 + triangle);
  mesh_->faces.push_back({a, b, c, centroid, n, range, key});
  face_cell_->push_back(cell.cell);
}

/// The faces whose normals are fitted: evenly strided, or consistentSample.
std::vector<size_t> drawSample(const LidarMesh& mesh, const LidarMeshSettings& s) {
  const int n_sample = s.sampled_faces > 0 ? s.sampled_faces : static_cast<int>(mesh.faces.size());
  if (!s.consistent_sample) return evenlyStrided(mesh.faces.size(), n_sample);
  std::vector<size_t> all(mesh.faces.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = i;
  return consistentSample(mesh.faces, all, n_sample);
}

/// The normal of a plane fit (PCA) to the points of the face's neighbourhood in the range image
/// (rings -1..+2, +-smooth_cols azimuth bins) that lie near the face's plane; the face's own
/// normal when the points are too few, not planar, or the fit is further than `cos_max` from it.
Eigen::Vector3f fittedNormal(const LidarScan& scan, const RangeImage& image, const MeshFace& face,
                             int face_cell, int smooth_cols, float cos_max) {
  const int r0 = face_cell / image.cols, c0 = face_cell % image.cols;
  const float tol = 0.02f * face.range + 0.05f;
  Eigen::Vector3f mean = Eigen::Vector3f::Zero();
  Eigen::Matrix3f second = Eigen::Matrix3f::Zero();
  int n = 0;
  for (int r = std::max(0, r0 - 1); r <= std::min(image.rings - 1, r0 + 2); ++r)
    for (int dc = -smooth_cols; dc <= smooth_cols + 1; ++dc) {
      const int i = image.at(r, c0 + dc);
      if (i < 0) continue;
      const Eigen::Vector3f p = pointOf(scan, i);
      if (std::fabs(face.normal.dot(p - face.centroid)) > tol) continue;
      mean += p;
      second += p * p.transpose();
      ++n;
    }
  if (n < 6) return face.normal;
  mean /= static_cast<float>(n);
  const Eigen::Matrix3f cov = second / static_cast<float>(n) - mean * mean.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f> eig(cov);
  // Planar: the smallest spread well below the other two (not a line of one ring's points).
  if (!(eig.eigenvalues()(0) < 0.1f * eig.eigenvalues()(1))) return face.normal;
  Eigen::Vector3f nf = eig.eigenvectors().col(0);
  if (nf.dot(face.normal) < 0) nf = -nf;
  return nf.dot(face.normal) > cos_max ? Eigen::Vector3f(nf.normalized()) : face.normal;
}

/// Replaces the normals of the sampled faces by fittedNormal's. A single face's normal is set by
/// a 3-10 cm edge along the ring, where 2 cm of range noise tilts it by degrees (lidar_mesh.h);
/// averaging neighbouring faces barely helps (they share vertices).
void fitSampleNormals(const LidarScan& scan, const RangeImage& image,
                      const std::vector<size_t>& sample, const std::vector<int>& face_cell,
                      const LidarMeshSettings& s, LidarMesh* mesh) {
  const float cos_max = static_cast<float>(std::cos(s.smooth_max_angle_deg * M_PI / 180.0));
  // A range image of few columns (a sparse ring) must not wrap the window onto itself: every
  // point at most once.
  const int smooth_cols = std::min(s.smooth_cols, std::max(0, (image.cols - 2) / 2));
  std::vector<Eigen::Vector3f> fitted(sample.size());
  const int n_sample = static_cast<int>(sample.size());
  // Each face writes only its own fitted normal: the same mesh on any number of threads.
  parallelForRanges(n_sample, resolveThreads(s.threads), 64, [&](int begin, int end) {
    for (int j = begin; j < end; ++j) {
      const size_t f = sample[j];
      fitted[j] = fittedNormal(scan, image, mesh->faces[f], face_cell[f], smooth_cols, cos_max);
    }
  });
  for (int j = 0; j < n_sample; ++j) mesh->faces[sample[j]].normal = fitted[j];
}

/// The scan's rings (its highest ring number + 1); throws beyond kMaxRings.
int ringCount(const LidarScan& scan) {
  int rings = 0;
  for (const auto& p : scan) rings = std::max(rings, int(p.ring) + 1);
  if (rings > kMaxRings)
    throw DataError("LiDAR scan has a ring number of " + std::to_string(rings - 1) +
                    "; rings are numbered from 0 and at most " + std::to_string(kMaxRings) +
                    " are supported (is the ring field something else?)");
  return rings;
}

}  // namespace

LidarMesh buildLidarMesh(const LidarScan& scan, const LidarMeshSettings& s) {
  if (s.azimuth_bins < 16 || s.azimuth_bins > kMaxAzimuthBins || s.smooth_cols < 0 ||
      s.smooth_cols > s.azimuth_bins / 4 || !(s.min_range >= 0) || !(s.max_range > s.min_range))
    throw DataError("LiDAR mesh settings: azimuth_bins must be in [16, " +
                    std::to_string(kMaxAzimuthBins) +
                    "], smooth_cols in [0, azimuth_bins / 4], 0 <= min_range < max_range");
  LidarMesh mesh;
  if (scan.empty()) return mesh;
  const RangeImage image =
      buildRangeImage(scan, ringCount(scan), s.azimuth_bins, s.min_range, s.max_range);
  std::vector<int> face_cell;  // ring * cols + col of each face
  Triangulation(scan, image, s).run(&mesh, &face_cell);
  const std::vector<size_t> sample = drawSample(mesh, s);
  mesh.consistent_sample = s.consistent_sample;
  mesh.sample.assign(sample.begin(), sample.end());
  if (s.smooth_cols > 0) fitSampleNormals(scan, image, sample, face_cell, s, &mesh);
  // A keyframe keeps its mesh for the window's lifetime: not the up to 2x capacity push_back
  // left (heaptrack of a long online run: the meshes' growth was its largest peak consumer).
  mesh.faces.shrink_to_fit();
  return mesh;
}

}  // namespace tescalib
