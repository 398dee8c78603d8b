// The pinhole camera model of the rectified images: the paper's K in the key point projection
// function (Eq. affine_transformation), d p = K X and X = d K^-1 p.
//
// Each function keeps the scalar type of its intrinsics: float intrinsics project in float (the
// simulator, the mesh depth rasteriser), double ones in double and ceres::Jet ones (residuals)
// in Jet arithmetic. The evaluation order is fixed, (fx * x) / z + cx and ((u - cx) / fx) * z,
// and every caller's results depend on it to the last bit.
#pragma once

#include <type_traits>

#include <Eigen/Core>

namespace tescalib {

/// The pixel (u, v) = (fx x / z + cx, fy y / z + cy) of the camera-frame point p (x, y, z) =
/// (p[0], p[1], p[2]): an Eigen vector or a plain array of T.
template <typename T, typename P>
Eigen::Matrix<T, 2, 1> projectPinhole(const T& fx, const T& fy, const T& cx, const T& cy,
                                      const P& p) {
  static_assert(std::is_same<std::decay_t<decltype(fx * p[0])>, T>::value,
                "projectPinhole: the point's scalar would change the intrinsics' precision");
  return Eigen::Matrix<T, 2, 1>(fx * p[0] / p[2] + cx, fy * p[1] / p[2] + cy);
}

/// The ray ((u - cx) / fx, (v - cy) / fy, 1) through pixel (u, v): the normalised image
/// coordinates of the pixel, the camera-frame point at depth 1.
template <typename T>
Eigen::Matrix<T, 3, 1> pinholeRay(const T& fx, const T& fy, const T& cx, const T& cy, const T& u,
                                  const T& v) {
  return Eigen::Matrix<T, 3, 1>((u - cx) / fx, (v - cy) / fy, T(1));
}

/// The camera-frame point at depth z seen in pixel (u, v): z times pinholeRay.
template <typename T>
Eigen::Matrix<T, 3, 1> backProjectPinhole(const T& fx, const T& fy, const T& cx, const T& cy,
                                          const T& u, const T& v, const T& z) {
  return Eigen::Matrix<T, 3, 1>((u - cx) / fx * z, (v - cy) / fy * z, z);
}

}  // namespace tescalib
