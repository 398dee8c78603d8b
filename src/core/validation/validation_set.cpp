#include "tescalib/core/validation/validation_set.h"

#include <string>

#include "tescalib/core/common/error.h"
#include "tescalib/core/common/parallel.h"
#include "tescalib/core/eval/lidar_stereo_agreement.h"

namespace tescalib {

const char* criterionName(Criterion c) {
  switch (c) {
    case Criterion::kEdgeAlignment:
      return "edge_alignment";
    case Criterion::kPhotometric:
      return "photometric_residual";
    case Criterion::kDisparity:
      return "disparity_residual";
  }
  return "";
}

const char* criterionUnit(Criterion c) {
  switch (c) {
    case Criterion::kEdgeAlignment:
      return "";
    case Criterion::kPhotometric:
      return "grey levels";
    case Criterion::kDisparity:
      return "px";
  }
  return "";
}

bool higherIsBetter(Criterion c) { return c == Criterion::kEdgeAlignment; }

std::array<Vector6d, kCriteria> defaultOptimumFloors() {
  const auto floor = [](double rx, double ry, double rz, double tx, double ty, double tz) {
    const double r = 1.0 / kDegPerRad, t = 0.01;
    return (Vector6d() << rx * r, ry * r, rz * r, tx * t, ty * t, tz * t).finished();
  };
  // deg x3, cm x3: the rms distance of each criterion's optima from the truth (28 optima each, from
  // the truth and from 0.3 deg / 3 cm off) on 14 generated 12-keyframe drives with real sensors'
  // errors (--realism kitti; 8 of the default rig, 6 of random rigs).
  return {floor(0.19, 0.08, 0.08, 2.2, 2.4, 4.2), floor(0.07, 0.11, 0.13, 3.4, 1.9, 5.5),
          floor(0.065, 0.12, 0.09, 2.3, 1.8, 7.0)};
}

ValidationSet::ValidationSet(const std::vector<Frame>& frames, const StereoRig& rig,
                             const ValidationSettings& settings)
    : rig_(rig), settings_(settings) {
  if (frames.empty()) throw DataError("validation: no frames to validate on");
  for (const Frame& f : frames) {
    const cv::Size size(rig.left.width, rig.left.height);
    if (f.left.size() != size || f.right.size() != size || f.left.depth() != CV_8U ||
        f.right.depth() != CV_8U)
      throw DataError("validation: frame " + std::to_string(f.index) +
                      ": the images are not two 8-bit images of the rig's size " +
                      std::to_string(size.width) + "x" + std::to_string(size.height));
  }
  frames_.resize(frames.size());
  parallelFor(static_cast<int>(frames.size()), resolveThreads(settings.threads), [&](int i) {
    Prepared& p = frames_[i];
    p.frame = frames[i];
    p.prepared = prepareFrame(p.frame.left, p.frame.right, p.frame.scan, settings_);
  });
}

PreparedFrame prepareFrame(const cv::Mat& left, const cv::Mat& right, const LidarScan& scan,
                           const ValidationSettings& settings) {
  PreparedFrame p;
  p.edges_left = edgeStrengthMap(left, settings.edges);
  p.edges_right = edgeStrengthMap(right, settings.edges);
  p.grey_left = photometricImage(left, settings.photometric);
  p.grey_right = photometricImage(right, settings.photometric);
  p.discontinuities = depthDiscontinuities(scan, settings.edges);
  return p;
}

void ValidationSet::updateClouds(const Eigen::Isometry3d& T_right_left) {
  if (clouds_valid_ && T_right_left.isApprox(clouds_T_right_left_, 1e-12)) return;
  StereoSettings stereo = settings_.stereo;
  stereo.threads = 1;
  parallelFor(static_cast<int>(frames_.size()), resolveThreads(settings_.threads), [&](int i) {
    Prepared& p = frames_[i];
    p.cloud = computeStereoCloud(p.frame.left, p.frame.right, rig_, T_right_left, stereo);
  });
  clouds_valid_ = true;
  clouds_T_right_left_ = T_right_left;
}

double preparedFrameScore(const PreparedFrame& p, const LidarScan& scan, const StereoCloud& cloud,
                          Criterion c, const StereoRig& rig, const Eigen::Isometry3d& T_cam_lidar,
                          const Eigen::Isometry3d& T_right_left,
                          const ValidationSettings& settings) {
  switch (c) {
    case Criterion::kEdgeAlignment: {
      int nl = 0, nr = 0;
      const double l = edgeAlignment(p.discontinuities, p.edges_left, rig.left, T_cam_lidar, &nl);
      const double r = edgeAlignment(p.discontinuities, p.edges_right, rig.right,
                                     T_right_left * T_cam_lidar, &nr);
      return nl + nr > 0 ? (l * nl + r * nr) / (nl + nr) : 0.0;
    }
    case Criterion::kPhotometric:
      return photometricConsistency(scan, p.grey_left, p.grey_right, rig, T_cam_lidar, T_right_left,
                                    settings.photometric)
          .residual;
    case Criterion::kDisparity:
      return lidarDisparityResidual(scan, cloud, T_cam_lidar).mean_truncated_abs_px;
  }
  return 0;
}

FrameScores ValidationSet::score(const Eigen::Isometry3d& T_cam_lidar,
                                 const Eigen::Isometry3d& T_right_left,
                                 const std::vector<Criterion>& use) {
  FrameScores out;
  for (Criterion c : use) {
    if (c == Criterion::kDisparity) updateClouds(T_right_left);
    out[static_cast<int>(c)].assign(frames_.size(), 0.0);
  }
  parallelFor(static_cast<int>(frames_.size()), resolveThreads(settings_.threads), [&](int i) {
    for (Criterion c : use)
      out[static_cast<int>(c)][i] =
          preparedFrameScore(frames_[i].prepared, frames_[i].frame.scan, frames_[i].cloud, c, rig_,
                             T_cam_lidar, T_right_left, settings_);
  });
  return out;
}

}  // namespace tescalib
