// tescalib_error_budget: where the LiDAR-stereo solver's remaining error on a generated drive comes
// from. At the ground truth, the fine stage's associations (the solver's own sampling, noise model
// and Huber weights) are split with the generator's exact depth (sim::renderCameraDepth) into the
// stereo cloud's error (matched disparity vs the true one at the same pixel) and the LiDAR mesh's
// error (face centroid vs the true surface on the same ray). One Gauss-Newton step from the truth
// with each part alone says how far it pulls the estimate; the stereo part is broken down by
// surface orientation and depth. A developer's tool: it needs the generator, not a recording.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli.h"
#include "tescalib/core/common/error.h"
#include "tescalib/core/common/geometry.h"
#include "tescalib/core/common/pinhole.h"
#include "tescalib/core/io/kitti_calib.h"
#include "tescalib/core/sim/scene_builder.h"
#include "tescalib/core/sim/simulator.h"
#include "tescalib/core/sim/simulator_camera.h"
#include "tescalib/core/solvers/keyframe.h"
#include "tescalib/core/solvers/lidar_stereo_association.h"
#include "tescalib/core/solvers/lidar_stereo_covariance.h"
#include "tescalib/core/solvers/lidar_stereo_solver.h"

using namespace tescalib;

namespace {

const char* const kUsage = "usage: rosrun tescalib tescalib_error_budget [OPTIONS]";
const char* const kDescription =
    "Generates the drive (keyframes 0.5 s apart) and prints, at the ground truth, how far the "
    "fine stage's residuals pull T_cam_lidar: all of them, the stereo clouds' disparity error "
    "alone and the LiDAR mesh's error alone (one Gauss-Newton step, camera axes), the stereo part "
    "of the associations whose disparity error is below --tail-px and of the rest, then both parts "
    "by surface (road: normal within 37 deg of vertical; facing: within 14 deg of the optical "
    "axis; lateral: within 45 deg of camera x; other) and depth; then how a disparity offset "
    "of all stereo points, of the road's alone and a tilt across the image (an error of x px at "
    "normalised column x) move it, and the same for the lateral surfaces; then the disparity "
    "error fitted against the disparity's gradient and the normalised column, of all points, of "
    "the road's and of the lateral surfaces'.";

struct Args {
  SimOptions sim;
  int keyframes = 20;
  int keep_rings = 1;
  double tail_px = 0.25;  ///< disparity errors at least this large form the stereo part's tail
  bool random_rig = false;
  std::string calib;  ///< KITTI calib.txt whose P2, P3 and Tr become the rig
  KeyframeSettings ks;
};

bool parse(int argc, char** argv, Args* a) {
  using cli::add;
  using cli::to;
  CLI::App app(kDescription, "tescalib_error_budget");
  cli::setUp(&app, kUsage, "Options");
  add(
      &app, "--scenario", "NAME",
      [a](const std::string& v) {
        if (!sim::parseScenario(v, &a->sim.scenario)) throw std::invalid_argument(v);
      },
      "urban, residential or highway (default urban)");
  add(&app, "--seed", "S", to(&a->sim.seed, cli::toSeed),
      "the drive's seed, 0 to 2^53 (default 1)");
  // The drive is 5 frames a keyframe; the simulator takes at most 1e6 frames.
  add(&app, "--keyframes", "K",
      to(&a->keyframes,
         [](const std::string& v) {
           const int k = cli::toInt(v);
           if (k < 1 || k > 200000) throw std::invalid_argument(v);
           return k;
         }),
      "keyframes, 1 to 200000 (default 20)");
  add(
      &app, "--noise", "LEVEL",
      [a](const std::string& v) {
        if (!parseNoiseLevel(v, &a->sim.noise)) throw std::invalid_argument(v);
      },
      "default, none or high (default: default)");
  app.add_flag("--random-rig", a->random_rig,
               "the rig drawn from the seed (tescalib_simulate --rig random) instead of the "
               "default one");
  add(&app, "--calib", "FILE", to(&a->calib, cli::text),
      "KITTI calib.txt whose P2, P3 and Tr become the rig (after --random-rig: its image size and "
      "LiDAR mounting stay)");
  add(&app, "--refine-iterations", "N", to(&a->ks.stereo.refinement.iterations, cli::atLeast(0)),
      "rounds of the stereo clouds' disparity refinement (default 2)");
  add(&app, "--refine-smoothed-rounds", "N",
      to(&a->ks.stereo.refinement.smoothed_gradient_rounds, cli::atLeast(0)),
      "of those rounds, the first N take the smoothed gradient (default 1)");
  add(&app, "--sgbm-paths", "3|5|8", to(&a->ks.stereo.sgbm_paths, cli::toSgbmPaths),
      "SGBM's aggregation paths (default 3; 8 also aggregates from below)");
  add(&app, "--sgbm-both-ways", "0|1", to(&a->ks.stereo.sgbm_both_ways, cli::toSwitch),
      "match each pair upright and upside down and keep the mean (default 1)");
  add(&app, "--rectified-vertical-blur", "PX",
      to(&a->ks.stereo.rectified_vertical_blur_px, cli::toNonNegative),
      "low-pass along the columns of both images of a re-rectified pair before matching "
      "(Gaussian sigma, px; default 0.8; 0: off)");
  add(&app, "--refine-window", "R", to(&a->ks.stereo.refinement.window_radius, cli::atLeast(1)),
      "the refinement's window radius, px (default 4: 9x9 windows)");
  add(&app, "--keep-rings", "N", to(&a->keep_rings, cli::atLeast(1)),
      "keep every Nth laser ring (a sparser LiDAR: N = 4 leaves 16 rings)");
  add(&app, "--tail-px", "PX", to(&a->tail_px, cli::toNonNegative),
      "the stereo part's pull is also split into the associations whose disparity error is "
      "below PX and those at or above it (default 0.25)");
  return cli::parse(&app, argc, argv);
}

struct Part {
  Vector6d g = Vector6d::Zero();       ///< stereo part of sum w J r
  Vector6d g_mesh = Vector6d::Zero();  ///< mesh part
  double disparity_error = 0;          ///< px, summed
  double mesh_error = 0;               ///< m along the face normal, summed
  int n = 0;
};

void printPull(const char* name, const Matrix6d& H_inv, const Vector6d& g) {
  const Vector6d dx = -H_inv * g;
  std::printf("  %-7s rot [%+.4f %+.4f %+.4f] deg   trans [%+.2f %+.2f %+.2f] mm\n", name,
              dx[0] * kDegPerRad, dx[1] * kDegPerRad, dx[2] * kDegPerRad, dx[3] * 1e3, dx[4] * 1e3,
              dx[5] * 1e3);
}

/// The surfaces the budget is broken down by, each in three depth bands.
enum { kRoad, kFacing, kLateral, kOther, kClasses };
constexpr const char* kClassName[kClasses] = {"road", "facing", "lateral", "other"};
constexpr double kDepthEdges[] = {0, 10, 20, 40};

/// The fine stage's normal equations at the ground truth and the pulls of their parts.
/// One kind of surface's common biases: the pulls per px of a disparity offset and of a tilt b x
/// across the image (x the normalised column), and its disparity error fitted as a + b x.
struct SurfaceBias {
  Vector6d g_offset = Vector6d::Zero(), g_tilt = Vector6d::Zero();
  Eigen::Matrix2d A = Eigen::Matrix2d::Zero();
  Eigen::Vector2d y = Eigen::Vector2d::Zero();

  /// `g`: w J dr/dd of one association at normalised column `x`, disparity error `error`.
  void add(const Vector6d& g, double x, double error) {
    g_offset += g, g_tilt += g * x;
    const Eigen::Vector2d xr(1.0, x);
    A += xr * xr.transpose(), y += xr * error;
  }
  Eigen::Vector2d fit() const { return A.ldlt().solve(y); }
};

struct Budget {
  Matrix6d H = Matrix6d::Zero();
  Part all, stereo, mesh;
  Part stereo_core, stereo_tail;  ///< the stereo part below and at or above Args::tail_px
  double tail_px = 0.25;
  std::vector<Part> by_class = std::vector<Part>(kClasses * 3);
  int skipped_edges = 0;
  /// sum w J dr/db for a disparity offset of every stereo point and a tilt b x across the image
  Vector6d g_offset = Vector6d::Zero(), g_tilt = Vector6d::Zero();
  SurfaceBias road, lateral;  ///< the road's (onGround) and the lateral surfaces' (onLateral)
  /// Normal equations of the disparity error fitted as a + b_u dd/du + b_v dd/dv + b_x x, x the
  /// rectified image's normalised column (a tilt of the error across the image)
  Eigen::Matrix4d slant_A = Eigen::Matrix4d::Zero();
  Eigen::Vector4d slant_y = Eigen::Vector4d::Zero();
};

/// Adds the disparity error `error` at rectified pixel `px` to the fit of the error against the
/// disparity's own gradient (central differences over 4 px; steps across depth edges left out)
/// and against the normalised column `x_n`.
void addSlantSample(const StereoCloud& st, const Eigen::Vector2d& px, double x_n, double error,
                    Budget* b) {
  double l, r, up, down;
  if (!st.disparityAt(px.x() - 2, px.y(), &l) || !st.disparityAt(px.x() + 2, px.y(), &r) ||
      !st.disparityAt(px.x(), px.y() - 2, &up) || !st.disparityAt(px.x(), px.y() + 2, &down))
    return;
  const Eigen::Vector4d x(1.0, (r - l) / 4, (down - up) / 4, x_n);
  if (std::fabs(x[1]) >= 1 || std::fabs(x[2]) >= 1 || std::fabs(error) >= 1) return;
  b->slant_A += x * x.transpose();
  b->slant_y += x * error;
}

/// The true point on the ray of camera-frame point `c` (the left camera's depth render `depth`,
/// intrinsics `K`): inverse depth is affine on a plane, so it is interpolated; false across a depth
/// edge of the rendered scene (no single true value there) or outside the image.
bool trueSurfacePoint(const cv::Mat& depth, const CameraIntrinsics& K, const Eigen::Vector3d& c,
                      Eigen::Vector3d* pt) {
  const Eigen::Vector2d px = K.project(c);
  const int u0 = static_cast<int>(std::floor(px.x())), v0 = static_cast<int>(std::floor(px.y()));
  if (u0 < 0 || v0 < 0 || u0 + 1 >= depth.cols || v0 + 1 >= depth.rows) return false;
  const float z[4] = {depth.at<float>(v0, u0), depth.at<float>(v0, u0 + 1),
                      depth.at<float>(v0 + 1, u0), depth.at<float>(v0 + 1, u0 + 1)};
  const float z_lo = *std::min_element(z, z + 4), z_hi = *std::max_element(z, z + 4);
  if (!(std::isfinite(z_lo) && std::isfinite(z_hi)) || z_hi - z_lo > 0.05f * z_lo) return false;
  const double fu = px.x() - u0, fv = px.y() - v0;
  const double inv_z =
      (1 - fv) * ((1 - fu) / z[0] + fu / z[1]) + fv * ((1 - fu) / z[2] + fu / z[3]);
  *pt = c / (c.z() * inv_z);
  return true;
}

/// One keyframe's fine-stage associations at the ground truth `T`, each split with the true
/// depth (`depth`, rendered for the left camera `K`) into its stereo and its mesh part. The
/// stereo cloud lives in the rectified frame (StereoCloud::R_rect_left), as the solver sees it.
void addKeyframe(const Keyframe& kf, const cv::Mat& depth, const CameraIntrinsics& K,
                 const Eigen::Isometry3d& T, Budget* b) {
  const LidarStereoSettings s;
  const StereoCloud& st = kf.stereo;
  const double fb = st.fx * st.baseline;
  for (size_t fi : sampleFaces(kf.mesh, s.fine_faces_per_keyframe)) {
    const MeshFace& f = kf.mesh.faces[fi];
    const Eigen::Vector3d c = T * f.centroid.cast<double>();
    const Eigen::Vector3d cr = st.R_rect_left * c;
    if (cr.z() < 1.0 || cr.z() > s.max_depth) continue;
    const Eigen::Vector2d px = projectPinhole(st.fx, st.fy, st.cx, st.cy, cr);
    double d;
    if (!st.disparityAt(px.x(), px.y(), &d)) continue;
    Eigen::Vector3d pt;
    if (!trueSurfacePoint(depth, K, c, &pt)) {
      ++b->skipped_edges;
      continue;
    }
    const double d_true = fb / (st.R_rect_left * pt).z();
    const double x_n = (px.x() - st.cx) / st.fx;  // the normalised column
    addSlantSample(st, px, x_n, d - d_true, b);
    const Eigen::Vector3d ps = st.pointAt(px.x(), px.y(), d);
    Eigen::Vector3d m = T.linear() * f.normal.cast<double>();
    // The fine stage's noise model, gate, residual normal and Huber weight (LidarStereoSettings
    // defaults).
    const double inv_sigma =
        pointPlaneInvSigma(m, c.normalized(), f.range, ps, d, 1.0, s.disparity_sigma, s);
    const double r = m.dot(c - ps) * inv_sigma;
    if (std::fabs(r) > s.fine_gate_sigma) continue;
    fineResidualNormal(st, px.x(), px.y(), s.fine_stereo_normal_px, c.normalized(), &m);
    const double w = std::fabs(r) <= s.fine_huber ? 1.0 : s.fine_huber / std::fabs(r);
    Vector6d J;
    J.head<3>() = m.cross(T.translation() - ps) * inv_sigma;
    J.tail<3>() = m * inv_sigma;
    b->H += w * J * J.transpose();
    const double r_stereo = m.dot(pt - ps) * inv_sigma, r_mesh = m.dot(c - pt) * inv_sigma;
    b->all.g += w * J * r, ++b->all.n;
    b->stereo.g += w * J * r_stereo;
    Part& side = std::fabs(d - d_true) < b->tail_px ? b->stereo_core : b->stereo_tail;
    side.g += w * J * r_stereo, side.disparity_error += d - d_true, ++side.n;
    b->mesh.g += w * J * r_mesh;
    const int cls = onGround(m)                            ? kRoad
                    : std::fabs(m.normalized().z()) > 0.97 ? kFacing
                    : onLateral(m)                         ? kLateral
                                                           : kOther;
    const double dr_dd = m.dot(ps) / d * inv_sigma;  // per px of disparity
    b->g_offset += w * J * dr_dd;
    b->g_tilt += w * J * dr_dd * x_n;
    if (cls == kRoad) b->road.add(w * J * dr_dd, x_n, d - d_true);
    if (cls == kLateral) b->lateral.add(w * J * dr_dd, x_n, d - d_true);
    const int band = pt.z() < kDepthEdges[1] ? 0 : pt.z() < kDepthEdges[2] ? 1 : 2;
    Part& p = b->by_class[cls * 3 + band];
    p.g += w * J * r_stereo, p.disparity_error += d - d_true, ++p.n;
    p.g_mesh += w * J * r_mesh, p.mesh_error += m.dot(c - pt);
  }
}

/// The pulls of all associations and of each part, then the parts by surface and depth.
void printBudget(const Budget& b) {
  const Matrix6d H_inv = b.H.inverse();
  std::printf("pull from the ground truth (camera axes x y z):\n");
  printPull("all", H_inv, b.all.g);
  printPull("stereo", H_inv, b.stereo.g);
  printPull("mesh", H_inv, b.mesh.g);
  std::printf("the stereo part by the size of the disparity error (mean error, share):\n");
  for (const Part* p : {&b.stereo_core, &b.stereo_tail}) {
    std::printf("  %s %.2f px: %+.4f px, %.1f %%\n", p == &b.stereo_core ? "below" : "at or above",
                b.tail_px, p->n ? p->disparity_error / p->n : 0.0, 100.0 * p->n / b.all.n);
    printPull(p == &b.stereo_core ? "core" : "tail", H_inv, p->g);
  }
  std::printf(
      "by surface and depth: the stereo part (mean disparity error, pull) and the mesh\n"
      "part (mean error along the face normal, towards the sensor positive; pull)\n"
      "  %-8s %-8s %6s %10s %8s %8s %9s %9s %9s %9s %8s %8s %9s\n",
      "surface", "depth m", "assoc", "dd (px)", "tz mm", "ty mm", "rx deg", "ry deg", "rz deg",
      "mesh mm", "tz mm", "ty mm", "rx deg");
  for (int k = 0; k < kClasses * 3; ++k) {
    const Part& p = b.by_class[k];
    if (!p.n) continue;
    const Vector6d dx = -H_inv * p.g, dm = -H_inv * p.g_mesh;
    std::printf(
        "  %-8s %2.0f-%-5.0f %6d %+10.4f %+8.2f %+8.2f %+9.4f %+9.4f %+9.4f %+9.2f %+8.2f %+8.2f "
        "%+9.4f\n",
        kClassName[k / 3], kDepthEdges[k % 3], kDepthEdges[k % 3 + 1], p.n, p.disparity_error / p.n,
        dx[5] * 1e3, dx[4] * 1e3, dx[0] * kDegPerRad, dx[1] * kDegPerRad, dx[2] * kDegPerRad,
        p.mesh_error / p.n * 1e3, dm[5] * 1e3, dm[4] * 1e3, dm[0] * kDegPerRad);
  }
}

/// What a disparity offset does (of every stereo point, of the road's alone) and the fit of the
/// disparity error against the disparity's gradient (a matcher's bias on slanted surfaces) and
/// the normalised column (a tilt across the image).
void printSensitivities(const Budget& b) {
  const Matrix6d H_inv = b.H.inverse();
  std::printf("the estimate's move per px of disparity offset (camera axes x y z):\n");
  printPull("all", H_inv, b.g_offset);
  printPull("road", H_inv, b.road.g_offset);
  std::printf("per px of disparity tilt (an error of x px at normalised column x):\n");
  printPull("tilt", H_inv, b.g_tilt);
  printPull("road", H_inv, b.road.g_tilt);
  std::printf("per px of disparity offset and tilt of the lateral surfaces:\n");
  printPull("offset", H_inv, b.lateral.g_offset);
  printPull("tilt", H_inv, b.lateral.g_tilt);
  const Eigen::Vector4d k = b.slant_A.ldlt().solve(b.slant_y);
  std::printf(
      "disparity error = %+.4f px %+.4f px * dd/du %+.4f px * dd/dv %+.4f px * x (%.0f stereo "
      "points)\n",
      k[0], k[1], k[2], k[3], b.slant_A(0, 0));
  const Eigen::Vector2d kr = b.road.fit(), kl = b.lateral.fit();
  std::printf("the road's disparity error = %+.4f px %+.4f px * x (%.0f associations)\n", kr[0],
              kr[1], b.road.A(0, 0));
  std::printf("the lateral surfaces' disparity error = %+.4f px %+.4f px * x (%.0f associations)\n",
              kl[0], kl[1], b.lateral.A(0, 0));
}

}  // namespace

int main(int argc, char** argv) {
  Args args;
  if (!parse(argc, argv, &args)) {
    std::cerr << "tescalib_error_budget: --help lists the options\n";
    return 2;
  }
  SimOptions& o = args.sim;
  const KeyframeSettings& ks = args.ks;
  o.frames = 5 * (args.keyframes - 1) + 1;
  if (args.random_rig) useRandomRig(o.seed, &o);
  std::unique_ptr<Simulator> sim_ptr;
  try {
    if (!args.calib.empty()) o.calib = readKittiOdometryCalib(args.calib);
    sim_ptr = std::make_unique<Simulator>(o);
  } catch (const DataError& e) {
    std::cerr << "tescalib_error_budget: " << e.what() << "\n";
    return 1;
  }
  const Simulator& sim = *sim_ptr;
  const StereoRig& rig = sim.rig();
  const Eigen::Isometry3d T = rig.T_cam_lidar;
  Budget budget;
  budget.tail_px = args.tail_px;
  for (int i = 0; i < o.frames; i += 5) {
    Frame frame = sim.renderFrame(i);
    keepEveryNthRing(&frame.scan, args.keep_rings);
    const Keyframe kf = makeKeyframe(frame, rig, T, rig.T_right_left, ks);
    const cv::Mat depth = sim::renderCameraDepth(sim.world(), rig.left,
                                                 sim.worldFromLidar(i) * T.inverse(), 250.f, 0);
    addKeyframe(kf, depth, rig.left, T, &budget);
  }
  std::printf(
      "tescalib_error_budget: %s drive, seed %llu, %d keyframes, noise %s, SGBM paths %d%s, "
      "refinement rounds %d (%d smoothed)\n",
      o.scenario == sim::Scenario::kUrban         ? "urban"
      : o.scenario == sim::Scenario::kResidential ? "residential"
                                                  : "highway",
      static_cast<unsigned long long>(o.seed), args.keyframes,
      o.noise == NoiseLevel::kNone   ? "none"
      : o.noise == NoiseLevel::kHigh ? "high"
                                     : "default",
      ks.stereo.sgbm_paths, ks.stereo.sgbm_both_ways ? " both ways" : "",
      ks.stereo.refinement.iterations,
      std::min(ks.stereo.refinement.smoothed_gradient_rounds, ks.stereo.refinement.iterations));
  std::printf(
      "  %d fine-stage associations at the ground truth (%d more across depth edges "
      "left out)\n",
      budget.all.n, budget.skipped_edges);
  if (budget.all.n < 100) {
    std::cerr << "tescalib_error_budget: too few associations\n";
    return 1;
  }
  printBudget(budget);
  printSensitivities(budget);
  return 0;
}
