#include "tescalib/core/sim/simulator_camera.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "tescalib/core/common/parallel.h"
#include "tescalib/core/common/pinhole.h"
#include "tescalib/core/sim/scene_surface.h"
#include "tescalib/core/sim/simulator_random.h"

namespace tescalib {
namespace sim {
namespace {

using Vec3 = Eigen::Vector3f;

constexpr int kTile = 16;
constexpr float kWhite = 235.f;             // scene value of a perfectly lit white surface
const Vec3 kAmbient(0.25f, 0.27f, 0.32f);   // sky light
const Vec3 kSunLight(0.85f, 0.82f, 0.74f);  // direct sun on a surface facing it
constexpr float kGamma = 0.6f;              // camera response: scene value ~ radiance^0.6

/// kWhite * r^kGamma for r in [0, 1], tabulated (three calls per sample).
class ToneCurve {
 public:
  ToneCurve() {
    for (int i = 0; i <= kSize; ++i)
      table_[i] = kWhite * std::pow(static_cast<float>(i) / kSize, kGamma);
  }
  float operator()(float r) const {
    const float x = std::clamp(r, 0.f, 1.f) * kSize;
    const int i = std::min(static_cast<int>(x), kSize - 1);
    return table_[i] + (x - i) * (table_[i + 1] - table_[i]);
  }

 private:
  static constexpr int kSize = 4096;
  float table_[kSize + 1];
};
const ToneCurve kTone;
const Vec3 kHorizon(0.86f, 0.88f, 0.9f);
const Vec3 kZenith(0.42f, 0.6f, 0.86f);
constexpr float kHazeDistance = 900.f;  // m; aerial perspective towards the horizon colour

/// One ray's result before the pixel's samples are averaged.
struct Sample {
  Vec3 value = Vec3::Zero();  ///< scene value, RGB (0..230)
  bool lit = false;           ///< in direct sun
};

/// The rays of camera K at pose T_world_cam: the image's samples and its depth render trace the
/// same ray through the same culled primitives.
class CameraRays {
 public:
  struct Ray {
    Vec3 r;     ///< through the image point, world frame, unit z in the camera frame
    float len;  ///< |r|
    Vec3 d;     ///< r / len
    TraceResult hit;
  };

  CameraRays(const SceneWorld& world, const CameraIntrinsics& K,
             const Eigen::Isometry3d& T_world_cam, float max_range, float lens_k1 = 0.f)
      : world_(world), K_(K), k1_(lens_k1) {
    R_ = T_world_cam.linear().cast<float>();
    origin_ = T_world_cam.translation().cast<float>();
    PinholeView view;
    view.R_cam_world = R_.transpose();
    view.origin = origin_;
    view.fx = static_cast<float>(K.fx), view.fy = static_cast<float>(K.fy);
    view.cx = static_cast<float>(K.cx), view.cy = static_cast<float>(K.cy);
    view.width = K.width, view.height = K.height;
    tiles_ = cullPinhole(world.prims, view, max_range, kTile);
  }

  /// Traces the ray through image point (u, v).
  Ray trace(float u, float v) const {
    Ray ray;
    Vec3 x = pinholeRay(float(K_.fx), float(K_.fy), float(K_.cx), float(K_.cy), u, v);
    if (k1_ != 0.f) x = undistorted(x);
    ray.r = R_ * x;
    ray.len = ray.r.norm();
    ray.d = ray.r / ray.len;
    const int tx = std::clamp(static_cast<int>(u) / kTile, 0, tiles_.tilesX() - 1);
    const int ty = std::clamp(static_cast<int>(v) / kTile, 0, tiles_.tilesY() - 1);
    ray.hit =
        traceRay(world_.prims, tiles_.begin(tx, ty), tiles_.end(tx, ty), origin_, ray.d, 1e5f);
    return ray;
  }

  const Eigen::Matrix3f& R() const { return R_; }
  const Vec3& origin() const { return origin_; }

 private:
  /// The ray (x, y, 1) whose distorted image point is `xd` (x (1 + k1 r^2) = xd, by fixed point).
  Vec3 undistorted(const Vec3& xd) const {
    Eigen::Vector2f x = xd.head<2>();
    for (int i = 0; i < 4; ++i) x = xd.head<2>() / (1.f + k1_ * x.squaredNorm());
    return Vec3(x.x(), x.y(), 1.f);
  }

  const SceneWorld& world_;
  const CameraIntrinsics& K_;
  float k1_;
  Eigen::Matrix3f R_;
  Vec3 origin_;
  TileCandidates tiles_;
};

class CameraRenderer {
 public:
  CameraRenderer(const SceneWorld& world, const SunShadowGrid& shadows, const CameraIntrinsics& K,
                 const Eigen::Isometry3d& T_world_cam, float max_range, float lens_k1)
      : world_(world), shadows_(shadows), rays_(world, K, T_world_cam, max_range, lens_k1) {
    step_x_ = rays_.R().col(0) / static_cast<float>(K.fx);
    step_y_ = rays_.R().col(1) / static_cast<float>(K.fy);
  }

  /// Traces and shades the ray through image point (u, v).
  Sample sample(float u, float v) const {
    const CameraRays::Ray ray = rays_.trace(u, v);
    const Vec3 &r = ray.r, &d = ray.d;
    const float len = ray.len;
    const TraceResult& hit = ray.hit;
    Sample s;
    if (hit.prim == TraceResult::kNoHit) {
      s.value = sky(d);
      return s;
    }
    SurfacePoint sp = surfaceAt(world_, hit, rays_.origin(), d);
    // Ray differentials: where the neighbouring pixels' rays meet the surface's tangent plane.
    const float lambda = hit.t / len;
    float nr = sp.normal.dot(r);
    if (std::fabs(nr) < 0.05f * len) nr = std::copysign(0.05f * len, nr);
    sp.dpdx = lambda * (step_x_ - (sp.normal.dot(step_x_) / nr) * r);
    sp.dpdy = lambda * (step_y_ - (sp.normal.dot(step_y_) / nr) * r);
    const SurfaceLook look = lookAt(world_, hit, sp);
    const float cos_sun = sp.normal.dot(world_.sun);
    s.lit = cos_sun > 0.f && shadows_.sunlit(sp.world + 0.01f * sp.normal);
    const Vec3 light =
        kAmbient * (0.8f + 0.2f * sp.normal.z()) + (s.lit ? cos_sun : 0.f) * kSunLight;
    const Vec3 radiance = look.albedo.cwiseProduct(light);
    const Vec3 surface(kTone(radiance.x()), kTone(radiance.y()), kTone(radiance.z()));
    const float haze = 1.f - std::exp(-hit.t / kHazeDistance);
    s.value = surface + haze * (kWhite * kHorizon - surface);
    return s;
  }

 private:
  static Vec3 sky(const Vec3& d) {
    const float up = std::sqrt(std::max(d.z(), 0.f));
    return kWhite * (kHorizon + up * (kZenith - kHorizon));
  }

  const SceneWorld& world_;
  const SunShadowGrid& shadows_;
  CameraRays rays_;
  Vec3 step_x_, step_y_;
};

}  // namespace

cv::Mat renderCamera(const SceneWorld& world, const SunShadowGrid& shadows,
                     const CameraIntrinsics& K, const Eigen::Isometry3d& T_world_cam,
                     const CameraExposure& exposure, const CameraRenderSettings& settings) {
  const CameraRenderer renderer(world, shadows, K, T_world_cam, settings.max_range,
                                settings.lens_k1);
  const int W = K.width, H = K.height;
  // Each pixel integrates the light over its area, as a camera's does: the mean of four
  // rotated-grid samples. A point sample per pixel would alias the finest texture detail, and two
  // cameras whose rows fall a fraction of a pixel apart on the scene (a real rectified pair whose
  // right camera sits a few mm off the left camera's x axis) would then see different images of
  // the same surface: a disparity error of up to 0.1 px on the road, of opposite sign for a
  // right camera above or below the axis (test Simulator.OffAxisPairSeesWhatTheLeftCameraSees).
  std::vector<Vec3> value(static_cast<size_t>(W) * H);
  static const float kOffsets[4][2] = {
      {-0.125f, -0.375f}, {0.375f, -0.125f}, {0.125f, 0.375f}, {-0.375f, 0.125f}};
  const int threads = resolveThreads(settings.threads);
  parallelFor(H, threads, [&](int y) {
    for (int x = 0; x < W; ++x) {
      Vec3 sum = Vec3::Zero();
      for (const auto& o : kOffsets) sum += renderer.sample(x + o[0], y + o[1]).value;
      value[static_cast<size_t>(y) * W + x] = 0.25f * sum;
    }
  });
  if (settings.blur_sigma_px > 0.f) {
    cv::Mat plane(H, W, CV_32FC3, value.data());
    cv::GaussianBlur(plane, plane, cv::Size(0, 0), settings.blur_sigma_px, 0, cv::BORDER_REPLICATE);
  }
  // Exposure and noise. Noise comes from a per-pixel hash, so it does not depend on threads.
  cv::Mat image(H, W, CV_8UC3);
  const float corner2 = static_cast<float>(std::max(K.cx * K.cx, (W - K.cx) * (W - K.cx)) +
                                           std::max(K.cy * K.cy, (H - K.cy) * (H - K.cy)));
  const uint32_t seed = static_cast<uint32_t>(settings.noise_seed ^ (settings.noise_seed >> 32));
  parallelFor(H, threads, [&](int y) {
    auto* row = image.ptr<cv::Vec3b>(y);
    const float dy2 = static_cast<float>((y - K.cy) * (y - K.cy));
    for (int x = 0; x < W; ++x) {
      const size_t i = static_cast<size_t>(y) * W + x;
      const float dx = static_cast<float>(x - K.cx);
      const float gain = exposure.gain * (1.f - settings.vignetting * (dx * dx + dy2) / corner2);
      for (int ch = 0; ch < 3; ++ch) {  // BGR
        float v = gain * value[i][2 - ch] + exposure.offset;
        if (settings.noise_sigma > 0.f)
          v += settings.noise_sigma *
               gaussianFromHash(hash32(seed, static_cast<uint32_t>(i), static_cast<uint32_t>(ch)));
        row[x][ch] = static_cast<uint8_t>(std::clamp(std::lround(v), 0L, 255L));
      }
    }
  });
  return image;
}

cv::Mat renderCameraDepth(const SceneWorld& world, const CameraIntrinsics& K,
                          const Eigen::Isometry3d& T_world_cam, float max_range, int threads) {
  const CameraRays rays(world, K, T_world_cam, max_range);
  cv::Mat depth(K.height, K.width, CV_32F);
  parallelFor(K.height, resolveThreads(threads), [&](int y) {
    float* row = depth.ptr<float>(y);
    for (int x = 0; x < K.width; ++x) {
      const CameraRays::Ray ray = rays.trace(x, y);  // the image's sample at the pixel centre
      row[x] = ray.hit.prim == TraceResult::kNoHit ? std::numeric_limits<float>::quiet_NaN()
                                                   : ray.hit.t / ray.len;
    }
  });
  return depth;
}

}  // namespace sim
}  // namespace tescalib
