#include "tescalib/core/eval/gicp_baseline.h"

#include <pcl/filters/voxel_grid.h>
#include <pcl/point_types.h>
#include <pcl/registration/gicp.h>

namespace tescalib {

GicpBaselineResult solveGicpBaseline(const std::vector<const Keyframe*>& window,
                                     const Eigen::Isometry3d& T_init,
                                     const GicpBaselineSettings& s) {
  using Cloud = pcl::PointCloud<pcl::PointXYZ>;
  GicpBaselineResult out;
  out.T_cam_lidar = T_init;
  Eigen::Vector4d q_sum = Eigen::Vector4d::Zero();
  Eigen::Vector3d t_sum = Eigen::Vector3d::Zero();
  const Eigen::Quaterniond q_ref(T_init.linear());
  int n = 0;
  bool all = !window.empty();
  double fitness = 0;
  for (const Keyframe* kf : window) {
    Cloud::Ptr src(new Cloud), tgt(new Cloud), src_f(new Cloud), tgt_f(new Cloud);
    // LiDAR points the camera can see: the mesh vertices' support is the view-filtered scan.
    const Eigen::Vector3d axis = T_init.linear().transpose() * Eigen::Vector3d::UnitZ();
    for (const auto& p : kf->scan) {
      const Eigen::Vector3d v(p.x, p.y, p.z);
      const double r = v.norm();
      if (r < 2.0 || r > s.max_depth || v.dot(axis) < 0.5 * r) continue;
      src->push_back(pcl::PointXYZ(p.x, p.y, p.z));
    }
    for (const auto& sp : kf->stereo.points)
      if (sp.p.z() < s.max_depth) tgt->push_back(pcl::PointXYZ(sp.p.x(), sp.p.y(), sp.p.z()));
    if (src->size() < 100 || tgt->size() < 100) {
      all = false;
      continue;
    }
    pcl::VoxelGrid<pcl::PointXYZ> vg;
    vg.setLeafSize(float(s.voxel), float(s.voxel), float(s.voxel));
    vg.setInputCloud(src);
    vg.filter(*src_f);
    vg.setInputCloud(tgt);
    vg.filter(*tgt_f);
    pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> gicp;
    gicp.setInputSource(src_f);
    gicp.setInputTarget(tgt_f);
    gicp.setMaxCorrespondenceDistance(s.max_correspondence);
    gicp.setMaximumIterations(s.max_iterations);
    Cloud aligned;
    gicp.align(aligned, T_init.matrix().cast<float>());
    all = all && gicp.hasConverged();
    fitness += gicp.getFitnessScore();
    const Eigen::Matrix4d M = gicp.getFinalTransformation().cast<double>();
    Eigen::Quaterniond q(Eigen::Matrix3d(M.topLeftCorner<3, 3>()));
    q.normalize();
    if (q.dot(q_ref) < 0) q.coeffs() *= -1;
    q_sum += q.coeffs();
    t_sum += M.topRightCorner<3, 1>();
    ++n;
  }
  if (n > 0) {
    Eigen::Quaterniond q;
    q.coeffs() = q_sum / n;
    q.normalize();
    out.T_cam_lidar.linear() = q.toRotationMatrix();
    out.T_cam_lidar.translation() = t_sum / n;
    out.fitness = fitness / n;
  }
  out.converged = all && n > 0;
  return out;
}

}  // namespace tescalib
