#include "tescalib/core/solvers/lidar_stereo_association.h"

#include <algorithm>
#include <cmath>

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_representation.h>
#include <pcl/point_types.h>

#include "tescalib/core/common/pinhole.h"
#include "tescalib/core/solvers/lidar_stereo_covariance.h"
#include "tescalib/core/solvers/residuals/point_plane_distance.h"
#include "tescalib/core/stereo/stereo_surface_normal.h"

namespace tescalib {
namespace {

/// [x, y, z, w nx, w ny, w nz]: the 6-D space of eq. KD6.
class SixDRepresentation : public pcl::PointRepresentation<pcl::PointNormal> {
 public:
  explicit SixDRepresentation(float w) : w_(w) { nr_dimensions_ = 6; }
  void copyToFloatArray(const pcl::PointNormal& p, float* out) const override {
    out[0] = p.x, out[1] = p.y, out[2] = p.z;
    out[3] = w_ * p.normal_x, out[4] = w_ * p.normal_y, out[5] = w_ * p.normal_z;
  }

 private:
  float w_;
};

/// The pixel (u, v) of a camera-frame point in the rectified left image of `st`, when it lies
/// within the stereo camera's depth range [1 m, max_depth]; false otherwise.
bool projectInDepthRange(const StereoCloud& st, const Eigen::Vector3d& c, double max_depth,
                         double* u, double* v) {
  const Eigen::Vector3d pr = st.R_rect_left * c;
  if (pr.z() < 1.0 || pr.z() > max_depth) return false;
  const Eigen::Vector2d px = projectPinhole(st.fx, st.fy, st.cx, st.cy, pr);
  *u = px.x(), *v = px.y();
  return true;
}

}  // namespace

double stereoYawGain(const StereoCloud& st, double u, double d) {
  const double xr = (u - d - st.cx) / st.fx;
  return st.fx * (1.0 + xr * xr);
}

Eigen::Vector3d correctedPoint(const LidarStereoAssociation& a, double scale, double yaw) {
  return correctedStereoScale(&scale, &yaw, a.d, a.g) * a.p_s;
}

bool fineResidualNormal(const StereoCloud& cloud, double u, double v, int h,
                        const Eigen::Vector3d& ray, Eigen::Vector3d* face_normal) {
  constexpr double kMaxFacingRatio = 3.0;
  // The ground keeps its own normal: seen at grazing angles, the road's stereo surface is the
  // noisiest, and with its normal a highway window (road and guard rails) claims to hold the
  // optical axis that it cannot hold.
  if (h <= 0 || onGround(*face_normal)) return false;
  Eigen::Vector3d n;
  if (!stereoSurfaceNormal(cloud, u, v, h, &n)) return false;
  if (n.dot(*face_normal) < 0) n = -n;
  const double lambda = face_normal->dot(ray) / n.dot(ray);
  if (!(lambda > 0) || !std::isfinite(lambda)) return false;  // facing it from the other side
  *face_normal = std::clamp(lambda, 1 / kMaxFacingRatio, kMaxFacingRatio) * n;
  return true;
}

// ------------------------------------------------------------------ eq. KD6 (coarse stage)

struct NormalSpaceAssociation::Trees {
  std::vector<pcl::KdTreeFLANN<pcl::PointNormal>> trees;
  std::vector<std::vector<size_t>> tree_index;  ///< stereo point of each tree point
  std::vector<std::vector<size_t>> face_index;  ///< the faces associated
};

NormalSpaceAssociation::NormalSpaceAssociation(const std::vector<const Keyframe*>& window,
                                               const LidarStereoSettings& s)
    : window_(window), settings_(s), trees_(std::make_unique<Trees>()) {
  trees_->trees.resize(window.size());
  trees_->tree_index.resize(window.size());
  trees_->face_index.resize(window.size());
  auto repr = std::make_shared<SixDRepresentation>(static_cast<float>(s.normal_weight));
  const int coarse_faces =
      std::min(s.coarse_faces_per_keyframe,
               s.coarse_faces_per_window / std::max(1, static_cast<int>(window.size())));
  for (size_t k = 0; k < window.size(); ++k) {
    const auto& pts = window[k]->stereo.points;
    std::vector<size_t>& tree_index = trees_->tree_index[k];
    tree_index = evenlyStrided(pts.size(), s.coarse_stereo_points_per_keyframe);
    trees_->face_index[k] = sampleFaces(window[k]->mesh, coarse_faces);
    if (tree_index.empty()) continue;
    pcl::PointCloud<pcl::PointNormal>::Ptr cloud(new pcl::PointCloud<pcl::PointNormal>);
    for (size_t i : tree_index) {
      pcl::PointNormal p;
      p.x = pts[i].p.x(), p.y = pts[i].p.y(), p.z = pts[i].p.z();
      p.normal_x = pts[i].n.x(), p.normal_y = pts[i].n.y(), p.normal_z = pts[i].n.z();
      cloud->push_back(p);
    }
    trees_->trees[k].setPointRepresentation(repr);
    trees_->trees[k].setInputCloud(cloud);
  }
}

NormalSpaceAssociation::~NormalSpaceAssociation() = default;

std::vector<LidarStereoAssociation> NormalSpaceAssociation::associate(const Eigen::Isometry3d& T,
                                                                      double scale,
                                                                      double gate) const {
  return associateKeyframes(window_.size(), settings_.threads,
                            [&](int k, std::vector<LidarStereoAssociation>* kf_as) {
                              associateKeyframe(k, T, scale, gate, kf_as);
                            });
}

void NormalSpaceAssociation::associateKeyframe(size_t k, const Eigen::Isometry3d& T, double scale,
                                               double gate,
                                               std::vector<LidarStereoAssociation>* out) const {
  const LidarStereoSettings& s = settings_;
  const std::vector<size_t>& tree_index = trees_->tree_index[k];
  if (tree_index.empty()) return;
  const Eigen::Matrix3d R = T.linear();
  std::vector<int> nn(1);
  std::vector<float> nn_d2(1);
  const auto& pts = window_[k]->stereo.points;
  const StereoCloud& st = window_[k]->stereo;
  for (size_t fi : trees_->face_index[k]) {
    const MeshFace& f = window_[k]->mesh.faces[fi];
    const Eigen::Vector3d q = R * f.centroid.cast<double>();
    const Eigen::Vector3d c = q + T.translation();
    const Eigen::Vector3d m = R * f.normal.cast<double>();
    // Only faces the stereo camera can have measured: in the image and in its depth range
    // (a far facade beyond the stereo range would otherwise pull the estimate forward).
    double u, v;
    if (!projectInDepthRange(st, c, s.max_depth, &u, &v)) continue;
    if (u < 0 || v < 0 || u >= st.disparity.cols || v >= st.disparity.rows) continue;
    pcl::PointNormal query;
    query.x = float(c.x() / scale), query.y = float(c.y() / scale), query.z = float(c.z() / scale);
    query.normal_x = float(m.x()), query.normal_y = float(m.y()), query.normal_z = float(m.z());
    if (trees_->trees[k].nearestKSearch(query, 1, nn, nn_d2) < 1 || nn_d2[0] > gate * gate)
      continue;
    const StereoPoint& sp = pts[tree_index[nn[0]]];
    LidarStereoAssociation a;
    a.q = q, a.m = m;
    a.p_l = f.centroid.cast<double>(), a.n_l = f.normal.cast<double>();
    a.p_s = sp.p.cast<double>(), a.n_s = sp.n.cast<double>();
    a.d = sp.disparity;
    const Eigen::Vector3d sr = st.R_rect_left * a.p_s;
    a.g = stereoYawGain(st, projectPinhole(st.fx, st.fy, st.cx, st.cy, sr).x(), a.d);
    // Point-to-plane noise: LiDAR along the normal plus stereo depth noise along it.
    const Eigen::Vector3d beam = c.normalized();
    a.inv_sigma =
        pointPlaneInvSigma(m, beam, f.range, a.p_s, sp.disparity, 1.0, s.disparity_sigma, s);
    out->push_back(a);
  }
}

size_t ringOffsetCount(const std::vector<LidarStereoAssociation>& associations) {
  int n = 0;
  for (const auto& a : associations) n = std::max(n, a.ring + 2);
  return static_cast<size_t>(n);
}

// ------------------------------------------------------- projective (fine stage, eq. 3)

ProjectiveAssociation::ProjectiveAssociation(const std::vector<const Keyframe*>& window,
                                             const LidarStereoSettings& s)
    : window_(window), settings_(s), face_index_(window.size()) {
  for (size_t k = 0; k < window.size(); ++k)
    face_index_[k] = sampleFaces(window[k]->mesh, s.fine_faces_per_keyframe);
}

std::vector<LidarStereoAssociation> ProjectiveAssociation::associate(const Eigen::Isometry3d& T,
                                                                     double scale,
                                                                     double yaw) const {
  return associateKeyframes(window_.size(), settings_.threads,
                            [&](int k, std::vector<LidarStereoAssociation>* kf_as) {
                              associateKeyframe(k, T, scale, yaw, kf_as);
                            });
}

void ProjectiveAssociation::associateKeyframe(size_t kf, const Eigen::Isometry3d& T, double scale,
                                              double yaw,
                                              std::vector<LidarStereoAssociation>* out) const {
  const LidarStereoSettings& s = settings_;
  const Eigen::Matrix3d R = T.linear();
  const StereoCloud& st = window_[kf]->stereo;
  const int cells = s.cov_cells_x * s.cov_cells_y;
  for (size_t fi : face_index_[kf]) {
    const MeshFace& f = window_[kf]->mesh.faces[fi];
    const Eigen::Vector3d q = R * f.centroid.cast<double>();
    const Eigen::Vector3d c = q + T.translation();
    double u, v, d;
    if (!projectInDepthRange(st, c, s.max_depth, &u, &v)) continue;
    if (!st.disparityAt(u, v, &d)) continue;
    const Eigen::Vector3d ps = st.pointAt(u, v, d);  // unscaled; the residual scales it
    Eigen::Vector3d m = R * f.normal.cast<double>();
    const double g = stereoYawGain(st, u, d);
    const double k = correctedStereoScale(&scale, &yaw, d, g);
    // The point sits at the yaw-corrected disparity (the clamp of correctedStereoScale): its
    // depth noise is that disparity's (with the clouds 0.3 deg off in yaw the raw disparity
    // weights far points up to 2.6x wrong).
    const double inv_sigma = pointPlaneInvSigma(
        m, c.normalized(), f.range, ps, std::max(d + g * yaw, 0.1 * d), k, s.disparity_sigma, s);
    if (std::fabs(m.dot(c - k * ps)) * inv_sigma > s.fine_gate_sigma) continue;
    fineResidualNormal(st, u, v, s.fine_stereo_normal_px, c.normalized(), &m);
    const int cell =
        std::clamp(static_cast<int>(u * s.cov_cells_x / st.disparity.cols), 0, s.cov_cells_x - 1) +
        s.cov_cells_x * std::clamp(static_cast<int>(v * s.cov_cells_y / st.disparity.rows), 0,
                                   s.cov_cells_y - 1);
    out->push_back({q, m, f.centroid.cast<double>(), R.transpose() * m, ps, Eigen::Vector3d::Zero(),
                    inv_sigma, static_cast<int>(kf) * cells + cell, d, g,
                    static_cast<int>(f.key >> 16), (f.key & 1u) ? 1.0 / 3 : 2.0 / 3,
                    m.dot(q) / f.range});
  }
}

}  // namespace tescalib
