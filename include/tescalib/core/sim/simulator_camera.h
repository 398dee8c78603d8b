// Renders a rectified pinhole image of a generated world: ray casting with exact geometry,
// procedural textures, sun light with cast shadows plus sky light, every pixel the mean of four
// rotated-grid samples over its area, haze, and per-camera affine brightness (gain, offset) with
// Gaussian image noise; optionally a residual lens distortion, blur and vignetting.
#pragma once

#include <cstdint>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "tescalib/core/common/types.h"
#include "tescalib/core/sim/scene_builder.h"
#include "tescalib/core/sim/scene_culling.h"

namespace tescalib {
namespace sim {

/// Brightness response of one camera: pixel = gain * scene value + offset + noise, where the
/// scene value (0..230) is the same for both cameras. So right = a * left + b with
/// a = gain_r / gain_l and b = offset_r - a * offset_l, before noise and rounding.
struct CameraExposure {
  float gain = 1.f;    ///< multiplies the scene value
  float offset = 0.f;  ///< added, grey levels
};

/// How one image is rendered.
struct CameraRenderSettings {
  float noise_sigma = 2.f;  ///< Gaussian image noise (grey levels, per channel)
  uint64_t noise_seed = 0;  ///< seed of the noise pattern (differs per frame and camera)
  float max_range = 250.f;  ///< primitives farther than this are not drawn (m)
  int threads = 1;          ///< rows are shared among this many threads
  /// Residual radial distortion of the rectified image: the scene point at normalised image
  /// coordinates x appears at x (1 + lens_k1 |x|^2).
  float lens_k1 = 0.f;
  float blur_sigma_px = 0.f;  ///< Gaussian blur of the optics (px; 0: none)
  /// Brightness lost at the image's corners (fraction): the gain falls off as 1 - v (r /
  /// r_corner)^2.
  float vignetting = 0.f;
};

/// Renders the image (CV_8UC3, BGR) of camera `K` at pose `T_world_cam` (optical frame: x right,
/// y down, z forward). `shadows` must have been built for the world's sun around the camera.
cv::Mat renderCamera(const SceneWorld& world, const SunShadowGrid& shadows,
                     const CameraIntrinsics& K, const Eigen::Isometry3d& T_world_cam,
                     const CameraExposure& exposure, const CameraRenderSettings& settings);

/// The exact depth (z along the optical axis, m; NaN where the ray meets no surface) at every
/// pixel centre of the same camera: the ground truth of a stereo matcher on the rendered pair.
cv::Mat renderCameraDepth(const SceneWorld& world, const CameraIntrinsics& K,
                          const Eigen::Isometry3d& T_world_cam, float max_range = 250.f,
                          int threads = 1);

}  // namespace sim
}  // namespace tescalib
