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
#include "tescalib/core/sim/scene_builder.h"
#include "tescalib/core/sim/simulator.h"
#include "tescalib/core/sim/simulator_camera.h"
#include "tescalib/core/solvers/keyframe.h"
#include "tescalib/core/solvers/lidar_stereo_solver.h"

using namespace tescalib;

namespace {

void usage() {
  std::cout << "usage: rosrun tescalib tescalib_error_budget\n"
               "         [--scenario urban|residential|highway] [--seed S] [--keyframes K]\n"
               "         [--noise default|none|high] [--refine-iterations N]\n"
               "         [--refine-smoothed-rounds N] [--keep-rings N]\n"
               "  Generates the drive (keyframes 0.5 s apart; default urban, seed 1, 20\n"
               "  keyframes, default noise) and prints, at the ground truth, how far the fine\n"
               "  stage's residuals pull T_cam_lidar: all of them, the stereo clouds' disparity\n"
               "  error alone and the LiDAR mesh's error alone (one Gauss-Newton step, camera\n"
               "  axes), then both parts by surface (road: normal within 37 deg of vertical;\n"
               "  facing: within 14 deg of the optical axis; lateral: within 45 deg of camera x;\n"
               "  other) and depth. --keep-rings N keeps every Nth laser ring (a sparser LiDAR:\n"
               "  N = 4 leaves 16 rings).\n";
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

}  // namespace

int main(int argc, char** argv) {
  SimOptions o;
  int keyframes = 20;
  int keep_rings = 1;
  KeyframeSettings ks;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      if (a == "-h" || a == "--help") {
        usage();
        return 0;
      }
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      const std::string v = argv[++i];
      auto number = [&](auto parse) {
        try {
          size_t used = 0;
          const auto x = parse(v, &used);
          if (used == v.size()) return x;
        } catch (const std::exception&) {
        }
        throw std::invalid_argument(a + " needs a number, not '" + v + "'");
      };
      auto to_int = [](const std::string& t, size_t* used) { return std::stoi(t, used); };
      if (a == "--scenario") {
        if (!sim::parseScenario(v, &o.scenario)) throw std::invalid_argument("--scenario " + v);
      } else if (a == "--seed") {
        try {
          o.seed = cli::toSeed(v);
        } catch (const std::exception&) {
          throw std::invalid_argument("--seed needs a whole number from 0 to 2^53, not '" + v +
                                      "'");
        }
      } else if (a == "--keyframes") {
        keyframes = number(to_int);
        // The drive is 5 frames a keyframe; the simulator takes at most 1e6 frames.
        if (keyframes < 1 || keyframes > 200000)
          throw std::invalid_argument("--keyframes must be 1 to 200000, not " + v);
      } else if (a == "--keep-rings") {
        keep_rings = number(to_int);
        if (keep_rings < 1) throw std::invalid_argument("--keep-rings " + v);
      } else if (a == "--noise") {
        if (!parseNoiseLevel(v, &o.noise)) throw std::invalid_argument("--noise " + v);
      } else if (a == "--refine-smoothed-rounds") {
        ks.stereo.refinement.smoothed_gradient_rounds = number(to_int);
        if (ks.stereo.refinement.smoothed_gradient_rounds < 0)
          throw std::invalid_argument(a + " " + v);
      } else if (a == "--refine-iterations") {
        ks.stereo.refinement.iterations = number(to_int);
        if (ks.stereo.refinement.iterations < 0) throw std::invalid_argument(a + " " + v);
      } else {
        throw std::invalid_argument("unknown option " + a);
      }
    }
  } catch (const std::exception& e) {
    std::cerr << "tescalib_error_budget: " << e.what() << " (--help for usage)\n";
    return 2;
  }
  o.frames = 5 * (keyframes - 1) + 1;
  std::unique_ptr<Simulator> sim_ptr;
  try {
    sim_ptr = std::make_unique<Simulator>(o);
  } catch (const DataError& e) {
    std::cerr << "tescalib_error_budget: " << e.what() << "\n";
    return 1;
  }
  const Simulator& sim = *sim_ptr;
  const StereoRig& rig = sim.rig();
  const Eigen::Isometry3d T = rig.T_cam_lidar;
  const double fb = rig.left.fx * rig.baseline();
  const LidarStereoSettings s;
  Matrix6d H = Matrix6d::Zero();
  Part all, stereo, mesh;
  enum { kRoad, kFacing, kLateral, kOther, kClasses };
  const char* class_name[kClasses] = {"road", "facing", "lateral", "other"};
  const double depth_edges[] = {0, 10, 20, 40};
  std::vector<Part> by_class(kClasses * 3);
  int skipped_edges = 0;
  for (int i = 0; i < o.frames; i += 5) {
    Frame frame = sim.renderFrame(i);
    keepEveryNthRing(&frame.scan, keep_rings);
    const Keyframe kf = makeKeyframe(frame, rig, T, rig.T_right_left, ks);
    const cv::Mat depth = sim::renderCameraDepth(sim.world(), rig.left,
                                                 sim.worldFromLidar(i) * T.inverse(), 250.f, 0);
    const StereoCloud& st = kf.stereo;
    for (size_t fi : sampleFaces(kf.mesh, s.fine_faces_per_keyframe)) {
      const MeshFace& f = kf.mesh.faces[fi];
      const Eigen::Vector3d c = T * f.centroid.cast<double>();
      if (c.z() < 1.0 || c.z() > s.max_depth) continue;
      const double u = st.fx * c.x() / c.z() + st.cx, v = st.fy * c.y() / c.z() + st.cy;
      double d;
      if (!st.disparityAt(u, v, &d)) continue;
      // The true disparity at (u, v): inverse depth is affine on a plane, so interpolate it;
      // pixels across a depth edge of the rendered scene have no single true value.
      const int u0 = static_cast<int>(std::floor(u)), v0 = static_cast<int>(std::floor(v));
      const float z[4] = {depth.at<float>(v0, u0), depth.at<float>(v0, u0 + 1),
                          depth.at<float>(v0 + 1, u0), depth.at<float>(v0 + 1, u0 + 1)};
      const float z_lo = *std::min_element(z, z + 4), z_hi = *std::max_element(z, z + 4);
      if (!(std::isfinite(z_lo) && std::isfinite(z_hi)) || z_hi - z_lo > 0.05f * z_lo) {
        ++skipped_edges;
        continue;
      }
      const double fu = u - u0, fv = v - v0;
      const double inv_z =
          (1 - fv) * ((1 - fu) / z[0] + fu / z[1]) + fv * ((1 - fu) / z[2] + fu / z[3]);
      const double d_true = fb * inv_z;
      const Eigen::Vector3d ps = st.pointAt(u, v, d), pt = st.pointAt(u, v, d_true);
      const Eigen::Vector3d m = T.linear() * f.normal.cast<double>();
      // The fine stage's noise model, gate and Huber weight (LidarStereoSettings defaults).
      const double inv_sigma =
          pointPlaneInvSigma(m, c.normalized(), f.range, ps, d, 1.0, s.disparity_sigma, s);
      const double r = m.dot(c - ps) * inv_sigma;
      if (std::fabs(r) > s.fine_gate_sigma) continue;
      const double w = std::fabs(r) <= s.fine_huber ? 1.0 : s.fine_huber / std::fabs(r);
      Vector6d J;
      J.head<3>() = m.cross(T.translation() - ps) * inv_sigma;
      J.tail<3>() = m * inv_sigma;
      H += w * J * J.transpose();
      const double r_stereo = m.dot(pt - ps) * inv_sigma, r_mesh = m.dot(c - pt) * inv_sigma;
      all.g += w * J * r, ++all.n;
      stereo.g += w * J * r_stereo;
      mesh.g += w * J * r_mesh;
      const int cls = std::fabs(m.y()) > 0.8    ? kRoad
                      : std::fabs(m.z()) > 0.97 ? kFacing
                      : std::fabs(m.x()) > 0.7  ? kLateral
                                                : kOther;
      const double Z = fb / d_true;
      const int band = Z < depth_edges[1] ? 0 : Z < depth_edges[2] ? 1 : 2;
      Part& p = by_class[cls * 3 + band];
      p.g += w * J * r_stereo, p.disparity_error += d - d_true, ++p.n;
      p.g_mesh += w * J * r_mesh, p.mesh_error += m.dot(c - pt);
    }
  }
  std::printf(
      "tescalib_error_budget: %s drive, seed %llu, %d keyframes, noise %s, refinement "
      "rounds %d (%d smoothed)\n",
      o.scenario == sim::Scenario::kUrban         ? "urban"
      : o.scenario == sim::Scenario::kResidential ? "residential"
                                                  : "highway",
      static_cast<unsigned long long>(o.seed), keyframes,
      o.noise == NoiseLevel::kNone   ? "none"
      : o.noise == NoiseLevel::kHigh ? "high"
                                     : "default",
      ks.stereo.refinement.iterations,
      std::min(ks.stereo.refinement.smoothed_gradient_rounds, ks.stereo.refinement.iterations));
  std::printf(
      "  %d fine-stage associations at the ground truth (%d more across depth edges "
      "left out)\n",
      all.n, skipped_edges);
  if (all.n < 100) {
    std::cerr << "tescalib_error_budget: too few associations\n";
    return 1;
  }
  const Matrix6d H_inv = H.inverse();
  std::printf("pull from the ground truth (camera axes x y z):\n");
  printPull("all", H_inv, all.g);
  printPull("stereo", H_inv, stereo.g);
  printPull("mesh", H_inv, mesh.g);
  std::printf(
      "by surface and depth: the stereo part (mean disparity error, pull) and the mesh\n"
      "part (mean error along the face normal, towards the sensor positive; pull)\n"
      "  %-8s %-8s %6s %10s %8s %8s %9s %9s %8s %8s %9s\n",
      "surface", "depth m", "assoc", "dd (px)", "tz mm", "ty mm", "rx deg", "mesh mm", "tz mm",
      "ty mm", "rx deg");
  for (int k = 0; k < kClasses * 3; ++k) {
    const Part& p = by_class[k];
    if (!p.n) continue;
    const Vector6d dx = -H_inv * p.g, dm = -H_inv * p.g_mesh;
    std::printf(
        "  %-8s %2.0f-%-5.0f %6d %+10.4f %+8.2f %+8.2f %+9.4f %+9.2f %+8.2f %+8.2f %+9.4f\n",
        class_name[k / 3], depth_edges[k % 3], depth_edges[k % 3 + 1], p.n, p.disparity_error / p.n,
        dx[5] * 1e3, dx[4] * 1e3, dx[0] * kDegPerRad, p.mesh_error / p.n * 1e3, dm[5] * 1e3,
        dm[4] * 1e3, dm[0] * kDegPerRad);
  }
  return 0;
}
