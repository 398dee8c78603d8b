#include "tescalib/core/disparity_refinement.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace tescalib {
namespace {

/// Window sum (unnormalised box filter, zero outside the image), in double precision.
cv::Mat windowSum(const cv::Mat& x, int r) {
  cv::Mat out;
  cv::boxFilter(x, out, CV_64F, cv::Size(2 * r + 1, 2 * r + 1), cv::Point(-1, -1), false,
                cv::BORDER_CONSTANT);
  return out;
}

/// The same in single precision (for sums of grey values, where it is exact enough and faster).
cv::Mat windowSumF(const cv::Mat& x, int r) {
  cv::Mat out;
  cv::boxFilter(x, out, CV_32F, cv::Size(2 * r + 1, 2 * r + 1), cv::Point(-1, -1), false,
                cv::BORDER_CONSTANT);
  return out;
}

/// First unknown of the symmetric 3x3 system [a00 a01 a02; a01 a11 a12; a02 a12 a22] x = b
/// (Cramer's rule); false when the system is (nearly) singular.
bool solveFirst(double a00, double a01, double a02, double a11, double a12, double a22, double b0,
                double b1, double b2, double* x0) {
  const double c00 = a11 * a22 - a12 * a12, c01 = a02 * a12 - a01 * a22,
               c02 = a01 * a12 - a02 * a11;
  const double det = a00 * c00 + a01 * c01 + a02 * c02;
  if (!(std::fabs(det) > 1e-9 * std::fabs(a00 * c00)) || !std::isfinite(det)) return false;
  *x0 = (c00 * b0 + c01 * b1 + c02 * b2) / det;
  return true;
}

}  // namespace

void refineDisparity(const cv::Mat& left_gray, const cv::Mat& right_gray, cv::Mat* disparity,
                     const DisparityRefinementSettings& s) {
  if (s.iterations <= 0 || disparity->empty()) return;
  CV_Assert(disparity->type() == CV_32F && left_gray.size() == disparity->size() &&
            right_gray.size() == disparity->size());
  cv::Mat L, R;
  left_gray.convertTo(L, CV_32F);
  right_gray.convertTo(R, CV_32F);
  // Central-difference x gradient of the right image (warped along with it).
  cv::Mat GR;
  const cv::Mat kernel = (cv::Mat_<float>(1, 3) << -0.5f, 0.f, 0.5f);
  cv::filter2D(R, GR, CV_32F, kernel, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);

  const int rows = disparity->rows, cols = disparity->cols, r = s.window_radius;
  const double n_window = (2.0 * r + 1) * (2.0 * r + 1);
  cv::Mat& d = *disparity;
  // Valid pixels: a disparity that lands inside the right image. The refinement never invalidates
  // a pixel, so the mask and the plane-fit moments that depend only on it are computed once.
  cv::Mat valid(d.size(), CV_32F), map_y(d.size(), CV_32F), U(d.size(), CV_32F),
      V(d.size(), CV_32F);
  for (int v = 0; v < rows; ++v) {
    const float* dv = d.ptr<float>(v);
    for (int u = 0; u < cols; ++u) {
      valid.at<float>(v, u) = std::isfinite(dv[u]) && u - dv[u] >= 1.f ? 1.f : 0.f;
      map_y.at<float>(v, u) = V.at<float>(v, u) = static_cast<float>(v);
      U.at<float>(v, u) = static_cast<float>(u);
    }
  }
  const cv::Mat Um = U.mul(valid), Vm = V.mul(valid);
  const cv::Mat s1 = windowSum(valid, r), sU = windowSum(Um, r), sV = windowSum(Vm, r),
                sUU = windowSum(Um.mul(U), r), sVV = windowSum(Vm.mul(V), r),
                sUV = windowSum(Um.mul(V), r);

  for (int it = 0; it < s.iterations; ++it) {
    const bool last = it + 1 == s.iterations;
    cv::Mat d0(d.size(), CV_32F), map_x(d.size(), CV_32F);
    for (int v = 0; v < rows; ++v) {
      const float* dv = d.ptr<float>(v);
      const float* m = valid.ptr<float>(v);
      float* z = d0.ptr<float>(v);
      float* mx = map_x.ptr<float>(v);
      for (int u = 0; u < cols; ++u) {
        z[u] = m[u] > 0.f ? dv[u] : 0.f;
        mx[u] = static_cast<float>(u) - z[u];
      }
    }
    cv::Mat W, G;
    cv::remap(R, W, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    cv::remap(GR, G, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    // Photometric normal equations of W = G delta + alpha L + beta over the valid pixels
    // (single precision suffices: grey values, 81-pixel windows).
    const cv::Mat Gm = G.mul(valid), Lm = L.mul(valid);
    const cv::Mat sGG = windowSumF(Gm.mul(G), r), sGL = windowSumF(Gm.mul(L), r),
                  sG = windowSumF(Gm, r), sLL = windowSumF(Lm.mul(L), r), sL = windowSumF(Lm, r),
                  sGW = windowSumF(Gm.mul(W), r), sLW = windowSumF(Lm.mul(W), r),
                  sW = windowSumF(W.mul(valid), r);
    // In the last round, the centre value comes from the local plane fit
    // d = c + a (u' - u) + b (v' - v) over the window: unbiased also where the window is only
    // partly valid, and it averages out SGBM's per-pixel noise. Earlier rounds keep d + delta.
    cv::Mat sD, sUD, sVD;
    if (last) sD = windowSum(d0, r), sUD = windowSum(d0.mul(U), r), sVD = windowSum(d0.mul(V), r);
    cv::parallel_for_(cv::Range(0, rows), [&](const cv::Range& range) {
      for (int v = range.start; v < range.end; ++v) {
        float* dv = d.ptr<float>(v);
        for (int u = 0; u < cols; ++u) {
          if (!std::isfinite(dv[u])) continue;
          const double n = s1.at<double>(v, u);
          if (n < s.min_valid_fraction * n_window) continue;
          const double gg = sGG.at<float>(v, u), g = sG.at<float>(v, u);
          // Texture along x after removing the window's mean gradient.
          if (gg / n - (g / n) * (g / n) < s.min_gradient * s.min_gradient) continue;
          double delta = 0;
          if (!solveFirst(gg, sGL.at<float>(v, u), g, sLL.at<float>(v, u), sL.at<float>(v, u), n,
                          sGW.at<float>(v, u), sLW.at<float>(v, u), sW.at<float>(v, u), &delta))
            continue;
          delta = std::clamp(delta, -s.max_step, s.max_step);
          if (!last) {
            dv[u] = static_cast<float>(dv[u] + delta);
            continue;
          }
          const double su = sU.at<double>(v, u), sv = sV.at<double>(v, u);
          const double sd = sD.at<double>(v, u);
          const double xx = sUU.at<double>(v, u) - 2.0 * u * su + n * u * u;
          const double yy = sVV.at<double>(v, u) - 2.0 * v * sv + n * v * v;
          const double xy = sUV.at<double>(v, u) - u * sv - v * su + n * u * v;
          const double x = su - n * u, y = sv - n * v;
          const double xd = sUD.at<double>(v, u) - u * sd, yd = sVD.at<double>(v, u) - v * sd;
          double c = 0;
          if (solveFirst(n, x, y, xx, xy, yy, sd, xd, yd, &c))
            dv[u] = static_cast<float>(c + delta);
        }
      }
    });
  }
}

}  // namespace tescalib
