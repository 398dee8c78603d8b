#include "tescalib/core/stereo/disparity_refinement.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace tescalib {
namespace {

/// Window sum (unnormalised box filter, zero outside the image), in single precision: the sums
/// are of grey values and of small integers, exact enough.
void windowSum(const cv::Mat& x, int r, cv::Mat* out) {
  cv::boxFilter(x, *out, CV_32F, cv::Size(2 * r + 1, 2 * r + 1), cv::Point(-1, -1), false,
                cv::BORDER_CONSTANT);
}

/// Centred window moment sum_{window} x(u', v') kx(u' - u) ky(v' - v) (zero outside the image):
/// a separable filter, so the plane fit needs no absolute-coordinate moments (whose differences
/// cancel badly in single precision).
void windowMoment(const cv::Mat& x, const cv::Mat& kx, const cv::Mat& ky, cv::Mat* out) {
  cv::sepFilter2D(x, *out, CV_32F, kx, ky, cv::Point(-1, -1), 0, cv::BORDER_CONSTANT);
}

enum { kGG, kGL, kG, kLL, kL, kGW, kLW, kW, kTerms };

/// The refinement's full-size images, kept per thread: a window's clouds are computed one after
/// another on each thread, and allocating some 30 fresh image buffers per cloud cost more
/// (zeroing new pages) than the arithmetic on them. A thread that has refined a 1241x376 pair
/// keeps 34 float images, about 63 MB, until it ends (36, 67 MB, with smoothed gradient rounds).
struct Buffers {
  cv::Mat L, R, GR, Rs, GRs, valid, map_y, s1, mx, my, mxx, myy, mxy, d0, map_x, W, G, sD, xD, yD;
  cv::Mat terms[kTerms], sums[kTerms];
};

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

/// Kernels of the centred window moments: 1, (u' - u) and (u' - u)^2 along one axis.
struct MomentKernels {
  cv::Mat ones, lin, sq;
  explicit MomentKernels(int r)
      : ones(2 * r + 1, 1, CV_32F), lin(2 * r + 1, 1, CV_32F), sq(2 * r + 1, 1, CV_32F) {
    for (int k = -r; k <= r; ++k) {
      ones.at<float>(k + r) = 1.f;
      lin.at<float>(k + r) = static_cast<float>(k);
      sq.at<float>(k + r) = static_cast<float>(k * k);
    }
  }
};

/// The grey images in single precision and the right image's central-difference x gradient
/// (warped along with it), also of the Gaussian-smoothed right image when `smoothed`.
void prepareImages(const cv::Mat& left_gray, const cv::Mat& right_gray,
                   const DisparityRefinementSettings& s, bool smoothed, Buffers* buf) {
  left_gray.convertTo(buf->L, CV_32F);
  right_gray.convertTo(buf->R, CV_32F);
  const cv::Mat kernel = (cv::Mat_<float>(1, 3) << -0.5f, 0.f, 0.5f);
  cv::filter2D(buf->R, buf->GR, CV_32F, kernel, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
  if (smoothed) {
    const int k =
        2 * static_cast<int>(std::ceil(2.0 * s.smoothed_gradient_sigma)) + 1;  // +-2 sigma
    cv::GaussianBlur(buf->R, buf->Rs, cv::Size(k, k), s.smoothed_gradient_sigma);
    cv::filter2D(buf->Rs, buf->GRs, CV_32F, kernel, cv::Point(-1, -1), 0, cv::BORDER_REPLICATE);
  }
}

/// Valid pixels: a disparity that lands inside the right image. The refinement never invalidates
/// a pixel, so the mask and the plane-fit moments that depend only on it are computed once.
void validMaskAndMoments(const cv::Mat& d, int r, const MomentKernels& kern, Buffers* buf) {
  cv::Mat &valid = buf->valid, &map_y = buf->map_y;
  valid.create(d.size(), CV_32F);
  map_y.create(d.size(), CV_32F);
  for (int v = 0; v < d.rows; ++v) {
    const float* dv = d.ptr<float>(v);
    float* m = valid.ptr<float>(v);
    float* my = map_y.ptr<float>(v);
    for (int u = 0; u < d.cols; ++u) {
      m[u] = std::isfinite(dv[u]) && u - dv[u] >= 1.f ? 1.f : 0.f;
      my[u] = static_cast<float>(v);
    }
  }
  windowSum(valid, r, &buf->s1);
  windowMoment(valid, kern.lin, kern.ones, &buf->mx);
  windowMoment(valid, kern.ones, kern.lin, &buf->my);
  windowMoment(valid, kern.sq, kern.ones, &buf->mxx);
  windowMoment(valid, kern.ones, kern.sq, &buf->myy);
  windowMoment(valid, kern.lin, kern.lin, &buf->mxy);
}

/// The right image and its gradient warped by the current disparity (d0: the disparity, 0 where
/// invalid); `smoothed_gradient` takes the smoothed image's gradient.
void warpRight(const cv::Mat& d, bool smoothed_gradient, Buffers* buf) {
  cv::Mat &d0 = buf->d0, &map_x = buf->map_x;
  d0.create(d.size(), CV_32F);
  map_x.create(d.size(), CV_32F);
  for (int v = 0; v < d.rows; ++v) {
    const float* dv = d.ptr<float>(v);
    const float* m = buf->valid.ptr<float>(v);
    float* z = d0.ptr<float>(v);
    float* mxp = map_x.ptr<float>(v);
    for (int u = 0; u < d.cols; ++u) {
      z[u] = m[u] > 0.f ? dv[u] : 0.f;
      mxp[u] = static_cast<float>(u) - z[u];
    }
  }
  cv::remap(buf->R, buf->W, map_x, buf->map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  cv::remap(smoothed_gradient ? buf->GRs : buf->GR, buf->G, map_x, buf->map_y, cv::INTER_LINEAR,
            cv::BORDER_REPLICATE);
}

/// Window sums of the photometric normal equations of W = G delta + alpha L + beta over the valid
/// pixels (single precision suffices: grey values, 81-pixel windows).
void normalEquationSums(int r, Buffers* buf) {
  cv::Mat* terms = buf->terms;
  const cv::Mat &valid = buf->valid, &G = buf->G, &L = buf->L, &W = buf->W;
  const int rows = valid.rows, cols = valid.cols;
  cv::parallel_for_(cv::Range(0, rows), [&](const cv::Range& range) {
    for (int v = range.start; v < range.end; ++v) {
      const float *m = valid.ptr<float>(v), *g = G.ptr<float>(v), *l = L.ptr<float>(v),
                  *w = W.ptr<float>(v);
      float* out[kTerms];
      for (int k = 0; k < kTerms; ++k) out[k] = terms[k].ptr<float>(v);
      for (int u = 0; u < cols; ++u) {
        const float gm = g[u] * m[u], lm = l[u] * m[u];
        out[kGG][u] = gm * g[u];
        out[kGL][u] = gm * l[u];
        out[kG][u] = gm;
        out[kLL][u] = lm * l[u];
        out[kL][u] = lm;
        out[kGW][u] = gm * w[u];
        out[kLW][u] = lm * w[u];
        out[kW][u] = w[u] * m[u];
      }
    }
  });
  for (int k = 0; k < kTerms; ++k) windowSum(terms[k], r, &buf->sums[k]);
}

/// One round's update of every refinable pixel: d + delta, or in the last round the local plane
/// fit d = c + a (u' - u) + b (v' - v) over the window plus delta (unbiased also where the window
/// is only partly valid, and it averages out SGBM's per-pixel noise).
void updateDisparity(const DisparityRefinementSettings& s, bool last, const Buffers& buf,
                     cv::Mat* disparity) {
  cv::Mat& d = *disparity;
  const int r = s.window_radius;
  const double n_window = (2.0 * r + 1) * (2.0 * r + 1);
  const cv::Mat &s1 = buf.s1, &mx = buf.mx, &my = buf.my, &mxx = buf.mxx, &myy = buf.myy,
                &mxy = buf.mxy;
  const cv::Mat &sD = buf.sD, &xD = buf.xD, &yD = buf.yD;
  const cv::Mat* sums = buf.sums;
  cv::parallel_for_(cv::Range(0, d.rows), [&](const cv::Range& range) {
    for (int v = range.start; v < range.end; ++v) {
      float* dv = d.ptr<float>(v);
      for (int u = 0; u < d.cols; ++u) {
        if (!std::isfinite(dv[u])) continue;
        const double n = s1.at<float>(v, u);
        if (n < s.min_valid_fraction * n_window) continue;
        const double gg = sums[kGG].at<float>(v, u), g = sums[kG].at<float>(v, u);
        // Texture along x after removing the window's mean gradient.
        if (gg / n - (g / n) * (g / n) < s.min_gradient * s.min_gradient) continue;
        double delta = 0;
        if (!solveFirst(gg, sums[kGL].at<float>(v, u), g, sums[kLL].at<float>(v, u),
                        sums[kL].at<float>(v, u), n, sums[kGW].at<float>(v, u),
                        sums[kLW].at<float>(v, u), sums[kW].at<float>(v, u), &delta))
          continue;
        delta = std::clamp(delta, -s.max_step, s.max_step);
        if (!last) {
          dv[u] = static_cast<float>(dv[u] + delta);
          continue;
        }
        double c = 0;
        if (solveFirst(n, mx.at<float>(v, u), my.at<float>(v, u), mxx.at<float>(v, u),
                       mxy.at<float>(v, u), myy.at<float>(v, u), sD.at<float>(v, u),
                       xD.at<float>(v, u), yD.at<float>(v, u), &c))
          dv[u] = static_cast<float>(c + delta);
      }
    }
  });
}

}  // namespace

void refineDisparity(const cv::Mat& left_gray, const cv::Mat& right_gray, cv::Mat* disparity,
                     const DisparityRefinementSettings& s) {
  if (s.iterations <= 0 || disparity->empty()) return;
  CV_Assert(disparity->type() == CV_32F && left_gray.size() == disparity->size() &&
            right_gray.size() == disparity->size());
  thread_local Buffers buf;
  const bool smoothed = s.smoothed_gradient_rounds > 0 && s.smoothed_gradient_sigma > 0;
  prepareImages(left_gray, right_gray, s, smoothed, &buf);
  const int r = s.window_radius;
  cv::Mat& d = *disparity;
  const MomentKernels kern(r);
  validMaskAndMoments(d, r, kern, &buf);
  // Per-pixel products of the photometric normal equations (masked by `valid`).
  for (int k = 0; k < kTerms; ++k) buf.terms[k].create(d.size(), CV_32F);
  for (int it = 0; it < s.iterations; ++it) {
    const bool last = it + 1 == s.iterations;
    warpRight(d, smoothed && it < s.smoothed_gradient_rounds, &buf);
    normalEquationSums(r, &buf);
    // The last round's plane fit needs the window moments of the disparity itself.
    if (last) {
      windowSum(buf.d0, r, &buf.sD);
      windowMoment(buf.d0, kern.lin, kern.ones, &buf.xD);
      windowMoment(buf.d0, kern.ones, kern.lin, &buf.yD);
    }
    updateDisparity(s, last, buf, disparity);
  }
}

}  // namespace tescalib
