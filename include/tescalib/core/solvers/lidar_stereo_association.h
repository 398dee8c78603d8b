// Data association of the LiDAR-stereo calibration (paper, "Coarse Calibration" and "Fine
// Calibration"): which stereo point each LiDAR mesh face is compared with. The coarse stage
// searches the nearest stereo point in the 6-D space of point and weighted normal (eq. KD6); the
// fine stage projects the face into the disparity image and takes the stereo point there
// (eq. point_point_normal_obj, F(d) at the face's pixel).
#pragma once

#include <memory>
#include <vector>

#include <Eigen/Geometry>

#include "tescalib/core/common/parallel.h"
#include "tescalib/core/solvers/keyframe.h"
#include "tescalib/core/solvers/lidar_stereo_solver.h"

namespace tescalib {

/// One LiDAR face and the stereo point it is compared with.
struct LidarStereoAssociation {
  Eigen::Vector3d q, m;      ///< R_ref p_m and R_ref n_m (camera orientation, before t)
  Eigen::Vector3d p_l, n_l;  ///< face centroid and normal in the LiDAR frame
  Eigen::Vector3d p_s, n_s;  ///< stereo point and normal (camera frame)
  double inv_sigma = 1.0;
  int cluster = 0;  ///< keyframe and image cell, for the cluster-robust covariance
  double d = 1.0;   ///< the stereo point's disparity (px)
  double g = 0.0;   ///< its disparity change per rad of right-camera yaw, f (1 + x_r^2)
  int ring = -1;    ///< the face's lower ring (range-image row; -1: not known)
  /// The share of the face's vertices on its lower ring (2/3 or 1/3; the rest on the next ring).
  double lower_share = 0.5;
  /// How far the face moves along its normal per metre of range offset of its points: n_l^T b,
  /// b the centroid's beam (LiDAR frame).
  double range_gain = 0.0;
};

/// The associations of every keyframe of a window of `n`: `fill(k, &list)` collects keyframe k's,
/// on `threads` threads, and the lists are joined in window order (the same set on any number of
/// threads).
template <typename Fill>
std::vector<LidarStereoAssociation> associateKeyframes(size_t n, int threads, Fill&& fill) {
  std::vector<std::vector<LidarStereoAssociation>> per_kf(n);
  parallelFor(static_cast<int>(n), threads, [&](int k) { fill(k, &per_kf[k]); });
  size_t total = 0;
  for (const auto& p : per_kf) total += p.size();
  std::vector<LidarStereoAssociation> all;
  all.reserve(total);
  for (const auto& p : per_kf) all.insert(all.end(), p.begin(), p.end());
  return all;
}

/// How many rings' range offsets `associations` involve: the highest face ring + 2 (a face spans
/// its ring and the next), 0 without rings.
size_t ringOffsetCount(const std::vector<LidarStereoAssociation>& associations);

/// Disparity change of a rectified stereo point per rad of right-camera yaw (see
/// correctedStereoScale): f (1 + x_r^2), x_r the normalised right image coordinate.
double stereoYawGain(const StereoCloud& st, double u, double d);

/// The vector a fine LiDAR-stereo residual is measured along (LidarStereoSettings::
/// fine_stereo_normal_px), for a LiDAR face with normal `*face_normal` (left camera frame) whose
/// centroid projects to rectified pixel (u, v) along the camera ray `ray` (unit), where the
/// residual is the stereo point's distance to the face, f^T (c - p_s). As the estimate moves c,
/// p_s slides along the stereo surface (it stays on the ray through c), and the residual changes
/// by lambda n_s^T dc, n_s the stereo surface's normal (oriented like the face's) and
/// lambda = (f^T ray) / (n_s^T ray): the residual's derivative, which replaces `*face_normal`.
/// Its value at the association is the same (c - p_s lies along the ray). lambda is held within
/// 1/3 - 3 (beyond, a depth edge or a surface seen at a grazing angle: the stereo surface's
/// normal is not the surface's there). Returns whether it replaced the face's normal: not with
/// h = 0, on the ground's faces (onGround), where the disparity shows no
/// surface (stereoSurfaceNormal) nor where the two surfaces face the camera from opposite sides.
bool fineResidualNormal(const StereoCloud& cloud, double u, double v, int h,
                        const Eigen::Vector3d& ray, Eigen::Vector3d* face_normal);

/// The stereo point of `a` as the clouds' scale and yaw place it.
Eigen::Vector3d correctedPoint(const LidarStereoAssociation& a, double scale, double yaw);

/// Eq. KD6: each LiDAR face (centroid and normal, at the current T) is associated with the
/// stereo point nearest to it in [x, y, z, w nx, w ny, w nz] (w = normal_weight), within a gate.
/// Holds one search tree per keyframe over an evenly strided subset of its stereo points, and the
/// faces the coarse stage draws from each mesh's sample. `window` and `settings` must outlive it.
class NormalSpaceAssociation {
 public:
  NormalSpaceAssociation(const std::vector<const Keyframe*>& window,
                         const LidarStereoSettings& settings);
  ~NormalSpaceAssociation();

  /// The associations at `T` (stereo points divided by the clouds' `scale`) within `gate` (m, in
  /// the 6-D space), faces outside the stereo camera's image or depth range left out.
  std::vector<LidarStereoAssociation> associate(const Eigen::Isometry3d& T, double scale,
                                                double gate) const;

 private:
  struct Trees;
  void associateKeyframe(size_t k, const Eigen::Isometry3d& T, double scale, double gate,
                         std::vector<LidarStereoAssociation>* out) const;

  const std::vector<const Keyframe*>& window_;
  const LidarStereoSettings& settings_;
  std::unique_ptr<Trees> trees_;
};

/// The fine stage's projective association: each LiDAR face (drawn from its mesh's sample) is
/// projected at the current T into the left image and compared with the stereo point of the
/// disparity there, weighted by the point-to-plane noise and gated at fine_gate_sigma. Each
/// association's cluster is its keyframe and image cell (cov_cells_x x cov_cells_y per image), its
/// ring the face's lower ring.
/// `window` and `settings` must outlive it.
class ProjectiveAssociation {
 public:
  ProjectiveAssociation(const std::vector<const Keyframe*>& window,
                        const LidarStereoSettings& settings);

  std::vector<LidarStereoAssociation> associate(const Eigen::Isometry3d& T, double scale,
                                                double yaw) const;

 private:
  void associateKeyframe(size_t k, const Eigen::Isometry3d& T, double scale, double yaw,
                         std::vector<LidarStereoAssociation>* out) const;

  const std::vector<const Keyframe*>& window_;
  const LidarStereoSettings& settings_;
  std::vector<std::vector<size_t>> face_index_;
};

}  // namespace tescalib
