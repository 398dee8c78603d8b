#include "tescalib/core/io/calibration_io.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <utility>

#include <Eigen/Geometry>

#include "tescalib/core/common/geometry.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {

namespace {

/// 12 significant digits: a file read back gives the extrinsic to better than 1e-12 (m, rad) and
/// stays readable (17 would print 0.001 as 0.0010000000000000002).
constexpr int kDigits = 12;

/// A YAML float: NaN and infinities in YAML's spelling (.nan, .inf), not C++'s "nan".
struct YamlNumber {
  double v;
};
std::ostream& operator<<(std::ostream& os, YamlNumber n) {
  if (std::isnan(n.v)) return os << ".nan";
  if (std::isinf(n.v)) return os << (n.v > 0 ? ".inf" : "-.inf");
  return os << n.v;
}

void yamlBlock(std::ostream& yaml, const std::string& name, const std::string& parent,
               const std::string& child, const Eigen::Isometry3d& T, const Matrix6d& cov,
               bool cov_known, const bool observable[6], bool estimated,
               const WeakDirection& weakest) {
  const Eigen::Quaterniond q(T.linear());
  yaml << name << ":\n  parent_frame: " << parent << "\n  child_frame: " << child
       << "\n  estimated: " << (estimated ? "true" : "false") << "\n  translation: ["
       << YamlNumber{T.translation().x()} << ", " << YamlNumber{T.translation().y()} << ", "
       << YamlNumber{T.translation().z()} << "]\n  rotation_xyzw: [" << YamlNumber{q.x()} << ", "
       << YamlNumber{q.y()} << ", " << YamlNumber{q.z()} << ", " << YamlNumber{q.w()} << "]\n";
  // A solve that ended before its covariance has none (the topics' sigma -1): null here, and no
  // axis trusted, rather than the placeholder's numbers.
  yaml << "  covariance_known: " << (cov_known ? "true" : "false") << "\n";
  if (!cov_known) {
    yaml << "  sigma_rot_deg: null\n  sigma_trans_m: null\n  trusted_axes: [false, false, false, "
            "false, false, false]\n  covariance_phi_tau: null\n";
    return;
  }
  yaml << "  sigma_rot_deg: [";
  for (int i = 0; i < 3; ++i)
    yaml << (i ? ", " : "") << YamlNumber{std::sqrt(cov(i, i)) * kDegPerRad};
  yaml << "]\n  sigma_trans_m: [";
  for (int i = 3; i < 6; ++i) yaml << (i > 3 ? ", " : "") << YamlNumber{std::sqrt(cov(i, i))};
  yaml << "]\n  trusted_axes: [";  // rx ry rz tx ty tz
  // A given extrinsic constrains nothing from the data (as on the topics): no axis is trusted.
  for (int i = 0; i < 6; ++i)
    yaml << (i ? ", " : "") << (estimated && observable[i] ? "true" : "false");
  yaml << "]\n  covariance_phi_tau: [";
  for (int i = 0; i < 36; ++i) yaml << (i ? ", " : "") << YamlNumber{cov(i / 6, i % 6)};
  yaml << "]\n";
  if (weakest.ratio > 0) {  // what the window constrained least, in trust-limit units
    yaml << "  weakest_direction:\n    ratio_to_trust_limit: " << YamlNumber{weakest.ratio}
         << "\n    in_words: \"" << describeDirection(weakest.direction)
         << "\"\n    direction_scaled_phi_tau: [";
    for (int i = 0; i < 6; ++i) yaml << (i ? ", " : "") << YamlNumber{weakest.direction[i]};
    yaml << "]\n";
  }
}

void staticPublisher(std::ostream& launch, const std::string& name, const std::string& parent,
                     const std::string& child, const Eigen::Isometry3d& T_parent_child) {
  const Eigen::Quaterniond q(T_parent_child.linear());
  const Eigen::Vector3d& t = T_parent_child.translation();
  launch << "  <node pkg=\"tf2_ros\" type=\"static_transform_publisher\" name=\"" << name
         << "\" args=\"" << t.x() << " " << t.y() << " " << t.z() << " " << q.x() << " " << q.y()
         << " " << q.z() << " " << q.w() << " " << parent << " " << child << "\"/>\n";
}

}  // namespace

std::string calibrationYaml(const OnlineEstimate& e, const CalibrationFrames& frames) {
  std::ostringstream yaml;
  yaml << std::setprecision(kDigits)
       << "# tescalib calibration (T_a_b maps points from b into a; covariance over\n"
       << "# [phi_x phi_y phi_z tau_x tau_y tau_z] in rad and m, R = Exp(phi) R_est, t = t_est + "
          "tau)\n"
       << "converged: " << (e.converged ? "true" : "false")
       << "\nkeyframes_used: " << e.keyframes_used << "\nstamp: " << std::fixed
       << std::setprecision(9) << e.stamp << std::defaultfloat << std::setprecision(kDigits)
       << "\n";
  yamlBlock(yaml, "T_cam_lidar", frames.left, frames.lidar, e.T_cam_lidar, e.cov_lidar,
            e.cov_lidar_known, e.observable_lidar, true, e.weakest_lidar);
  yamlBlock(yaml, "T_right_left", frames.right, frames.left, e.T_right_left, e.cov_stereo,
            e.cov_stereo_known, e.observable_stereo, e.stereo_estimated,
            e.stereo_estimated ? e.weakest_stereo : WeakDirection());
  return yaml.str();
}

std::string staticTransformLaunch(const OnlineEstimate& e, const CalibrationFrames& frames) {
  std::ostringstream launch;
  launch << std::setprecision(kDigits) << "<launch>\n";
  // tf's parent -> child transform maps child points into the parent: T_lidar_left etc.
  staticPublisher(launch, "tescalib_lidar_to_left", frames.lidar, frames.left,
                  e.T_cam_lidar.inverse());
  staticPublisher(launch, "tescalib_left_to_right", frames.left, frames.right,
                  e.T_right_left.inverse());
  launch << "</launch>\n";
  return launch.str();
}

KittiOdometryCalib calibrationAsKitti(const StereoRig& rig, const OnlineEstimate& e) {
  KittiOdometryCalib c;
  Eigen::Matrix<double, 3, 4> P2, P3;
  P2 << rig.left.K(), Eigen::Vector3d::Zero();
  P3 << rig.right.K(), rig.right.K() * e.T_right_left.translation();
  c.P[0] = c.P[2] = P2;
  c.P[1] = c.P[3] = P3;
  c.Tr = e.T_cam_lidar.matrix().topRows<3>();
  c.R_right_left = e.T_right_left.linear();
  return c;
}

std::string calibrationBaseProblem(const std::string& base) {
  if (base.empty() || base.back() == '/')
    return "'" + base + "' names a folder: give a file name without extension (BASE)";
  return "";
}

bool writeCalibrationFiles(const std::string& path, const StereoRig& rig, const OnlineEstimate& e,
                           const CalibrationFrames& frames, std::string* message) {
  namespace fs = std::filesystem;
  if (const std::string problem = calibrationBaseProblem(path); !problem.empty()) {
    *message = problem;
    return false;
  }
  // "result.yaml" means BASE "result" (not result.yaml.yaml).
  const std::string yaml = ".yaml";
  std::string base = path;
  if (base.size() > yaml.size() && base.compare(base.size() - yaml.size(), yaml.size(), yaml) == 0)
    base.resize(base.size() - yaml.size());
  // Checked again without the extension ("dir/.yaml" names the folder), and "." or ".." would
  // write hidden files named after the folder.
  const std::string name = fs::path(base).filename().string();
  if (!calibrationBaseProblem(base).empty() || name == "." || name == "..") {
    *message = "'" + path + "' names a folder: give a file name (BASE or BASE.yaml)";
    return false;
  }
  const fs::path folder = fs::path(base).parent_path();
  if (!folder.empty() && !fs::is_directory(folder)) {
    *message = "the folder \"" + folder.string() + "\" does not exist (nothing written)";
    return false;
  }
  const std::pair<std::string, std::string> files[3] = {
      {base + ".yaml", calibrationYaml(e, frames)},
      {base + "_calib.txt", kittiOdometryCalibText(calibrationAsKitti(rig, e))},
      {base + "_static_tf.launch", staticTransformLaunch(e, frames)}};
  // All three are written to .tmp files first and renamed only when every one was written, so a
  // failure to write (a full disk, a missing folder, no permission) leaves the previous set whole.
  // The renames themselves are not atomic as a set (they fail only in odd cases: a folder of
  // that name); the message then says which file is old.
  size_t written = 0;  // temporaries created (the last one possibly partly written)
  auto removeTemporaries = [&] {
    std::error_code ec;
    for (size_t i = 0; i < written; ++i) fs::remove(files[i].first + ".tmp", ec);
  };
  for (const auto& [path, text] : files) {
    const std::string tmp = path + ".tmp";
    std::ofstream out(tmp);
    if (out) ++written;
    if (out) out << text;
    if (out) out.close();  // a full disk can fail only here
    if (!out) {
      *message = "cannot write " + tmp + ": " + std::strerror(errno);
      removeTemporaries();
      return false;
    }
  }
  for (const auto& f : files)
    if (std::rename((f.first + ".tmp").c_str(), f.first.c_str()) != 0) {
      *message = "cannot rename " + f.first + ".tmp to " + f.first + ": " + std::strerror(errno) +
                 " (the files renamed before it are new, the others old)";
      removeTemporaries();
      return false;
    }
  *message = "wrote " + base + ".yaml, " + base + "_calib.txt, " + base + "_static_tf.launch";
  return true;
}

}  // namespace tescalib
