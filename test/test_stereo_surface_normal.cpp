// The stereo surface's normal from an affine fit of the disparity (stereo_surface_normal.h): exact
// on a plane, refused where the patch is mostly without disparity, less noisy than finite
// differences, and oriented like the LiDAR face it stands in for.
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "tescalib/core/solvers/lidar_stereo_association.h"
#include "tescalib/core/stereo/stereo_surface_normal.h"

using namespace tescalib;

namespace {

// A 400 x 300 rectified view (f 500 px, B 0.5 m) of the plane n . X = n0 (rectified frame), with
// the rectified frame turned 1 deg about x from the left camera's.
StereoCloud planeCloud(const Eigen::Vector3d& n, double n0) {
  StereoCloud st;
  st.fx = st.fy = 500, st.cx = 200, st.cy = 150, st.baseline = 0.5;
  st.R_rect_left = Eigen::AngleAxisd(M_PI / 180, Eigen::Vector3d::UnitX()).toRotationMatrix();
  st.disparity = cv::Mat(300, 400, CV_32F);
  for (int v = 0; v < 300; ++v)
    for (int u = 0; u < 400; ++u) {
      const Eigen::Vector3d ray((u - st.cx) / st.fx, (v - st.cy) / st.fy, 1.0);
      const double Z = n0 / n.dot(ray);  // the ray X = Z ray meets the plane
      st.disparity.at<float>(v, u) = static_cast<float>(st.fx * st.baseline / Z);
    }
  return st;
}

double angleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::min(1.0, std::fabs(a.normalized().dot(b.normalized())))) * 180 / M_PI;
}

const Eigen::Vector3d kWall = Eigen::Vector3d(0.6, -0.1, -0.8).normalized();  // slanted, facing us

}  // namespace

TEST(StereoSurfaceNormal, AnAffineDisparityGivesThePlanesNormal) {
  const StereoCloud st = planeCloud(kWall, -8.0);
  const Eigen::Vector3d expected = st.R_rect_left.transpose() * kWall;  // left camera frame
  for (const auto& uv :
       {Eigen::Vector2d(200, 150), Eigen::Vector2d(57.3, 40.8), Eigen::Vector2d(351.6, 262.2)}) {
    Eigen::Vector3d n;
    ASSERT_TRUE(stereoSurfaceNormal(st, uv.x(), uv.y(), 6, &n));
    EXPECT_NEAR(n.norm(), 1.0, 1e-12);
    // float disparities: exact to their rounding
    EXPECT_LT(angleDeg(n, expected), 2e-3) << "at " << uv.transpose();
    // the rectified frame's normal is not the answer: the 1 deg between the frames shows
    EXPECT_GT(angleDeg(n, kWall), 0.5);
  }
}

TEST(StereoSurfaceNormal, NeedsMostOfThePatch) {
  StereoCloud st = planeCloud(kWall, -8.0);
  Eigen::Vector3d n;
  EXPECT_FALSE(stereoSurfaceNormal(st, 200, 150, 0, &n));
  // The left half of the 13 x 13 patch around (200, 150) without disparity (an edge): 84 of 169
  // valid, below 60 %.
  for (int v = 144; v <= 156; ++v)
    for (int u = 194; u <= 200; ++u) st.disparity.at<float>(v, u) = std::nanf("");
  EXPECT_FALSE(stereoSurfaceNormal(st, 200, 150, 6, &n));
  // Three pixels to the right, 130 of 169 are valid and the fit is the plane's.
  ASSERT_TRUE(stereoSurfaceNormal(st, 203, 150, 6, &n));
  EXPECT_LT(angleDeg(n, st.R_rect_left.transpose() * kWall), 2e-3);
  // Near the image border only the part inside counts.
  EXPECT_TRUE(stereoSurfaceNormal(st, 2, 150, 6, &n));
  EXPECT_FALSE(stereoSurfaceNormal(st, 0, 0, 6, &n));
}

TEST(StereoSurfaceNormal, AveragesTheDisparityNoiseBetterThanFiniteDifferences) {
  StereoCloud st = planeCloud(kWall, -8.0);
  std::mt19937 rng(5);
  std::normal_distribution<float> noise(0.f, 0.3f);
  for (int v = 0; v < st.disparity.rows; ++v)
    for (int u = 0; u < st.disparity.cols; ++u) st.disparity.at<float>(v, u) += noise(rng);
  const Eigen::Vector3d truth = st.R_rect_left.transpose() * kWall;
  std::vector<double> fit, diff;
  for (int v = 20; v < 280; v += 20)
    for (int u = 20; u < 380; u += 20) {
      Eigen::Vector3d n;
      ASSERT_TRUE(stereoSurfaceNormal(st, u, v, 6, &n));
      fit.push_back(angleDeg(n, truth));
      const auto p = [&](int du, int dv) {
        return st.pointAt(u + du, v + dv, st.disparity.at<float>(v + dv, u + du));
      };
      diff.push_back(angleDeg((p(6, 0) - p(-6, 0)).cross(p(0, 6) - p(0, -6)), truth));
    }
  std::nth_element(fit.begin(), fit.begin() + fit.size() / 2, fit.end());
  std::nth_element(diff.begin(), diff.begin() + diff.size() / 2, diff.end());
  const double fit_median = fit[fit.size() / 2], diff_median = diff[diff.size() / 2];
  // Independent pixel noise: the tent-weighted slopes are 4.5x less noisy; the angle about as much.
  EXPECT_LT(fit_median * 3.5, diff_median) << fit_median << " vs " << diff_median << " deg";
  EXPECT_GT(fit_median * 9.0, diff_median) << fit_median << " vs " << diff_median << " deg";
}

TEST(StereoSurfaceNormal, TheFineResidualsNormalIsTheDistancesDerivative) {
  const StereoCloud st = planeCloud(kWall, -8.0);
  const Eigen::Vector3d truth = st.R_rect_left.transpose() * kWall;
  const double u = 120, v = 90;
  const Eigen::Vector3d ray =
      (st.R_rect_left.transpose() * Eigen::Vector3d((u - st.cx) / st.fx, (v - st.cy) / st.fy, 1))
          .normalized();
  // A face 0.2 m in front of the stereo surface along the ray, its normal 20 deg off.
  double d;
  ASSERT_TRUE(st.disparityAt(u, v, &d));
  const Eigen::Vector3d ps = st.pointAt(u, v, d), c = ps - 0.2 * ray;
  const Eigen::Vector3d face = Eigen::AngleAxisd(20 * M_PI / 180, Eigen::Vector3d::UnitY()) * truth;
  for (const double sign : {1.0, -1.0}) {
    const Eigen::Vector3d f = sign * face;
    Eigen::Vector3d m = f;
    EXPECT_TRUE(fineResidualNormal(st, u, v, 6, ray, &m));
    EXPECT_LT(angleDeg(m, truth), 2e-3);
    EXPECT_GT(m.dot(f), 0);
    // the same residual at the association
    EXPECT_NEAR(m.dot(c - ps), f.dot(c - ps), 1e-6);
    // and its change as the face moves 1 cm sideways: the stereo point at the new projection
    // slides along the surface
    const Eigen::Vector3d c2 = c + 0.01 * Eigen::Vector3d::UnitX();
    const Eigen::Vector3d pr = st.R_rect_left * c2;
    const double u2 = st.fx * pr.x() / pr.z() + st.cx, v2 = st.fy * pr.y() / pr.z() + st.cy;
    double d2;
    ASSERT_TRUE(st.disparityAt(u2, v2, &d2));
    const double moved = f.dot(c2 - st.pointAt(u2, v2, d2)) - f.dot(c - ps);
    EXPECT_NEAR(m.dot(c2 - c), moved, 0.03 * std::fabs(moved)) << moved;
    EXPECT_GT(std::fabs(f.dot(c2 - c) - moved), 0.3 * std::fabs(moved));  // the face's is wrong
    // 0: the face's own normal, untouched
    Eigen::Vector3d own = f;
    EXPECT_FALSE(fineResidualNormal(st, u, v, 0, ray, &own));
    EXPECT_EQ(own, f);
  }
  // Where the disparity shows no surface, the face keeps its normal.
  Eigen::Vector3d m = face;
  EXPECT_FALSE(fineResidualNormal(st, 0, 0, 6, ray, &m));
  EXPECT_EQ(m, face);
  // A face seen nearly edge-on where the stereo surface faces the camera: the derivative is held
  // at a third of the stereo surface's normal.
  const Eigen::Vector3d edge_on = (ray.cross(Eigen::Vector3d::UnitY()) + 0.05 * ray).normalized();
  m = -edge_on;
  EXPECT_TRUE(fineResidualNormal(st, u, v, 6, ray, &m));
  EXPECT_NEAR(m.norm(), 1.0 / 3, 1e-9);
  EXPECT_LT(angleDeg(m, truth), 2e-3);
  // The ground's face (normal within 37 deg of camera y) keeps its own normal.
  const Eigen::Vector3d ground = Eigen::Vector3d(0.1, -1.0, 0.3).normalized();
  m = ground;
  EXPECT_FALSE(fineResidualNormal(st, u, v, 6, ray, &m));
  EXPECT_EQ(m, ground);
}
