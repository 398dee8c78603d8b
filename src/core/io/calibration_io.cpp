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
#include <vector>

#include <yaml-cpp/yaml.h>
#include <Eigen/Geometry>

#include "tescalib/core/common/error.h"
#include "tescalib/core/common/geometry.h"
#include "tescalib/core/uncertainty/trust.h"

namespace tescalib {

namespace {

/// 12 significant digits: a file read back gives the extrinsic to better than 1e-12 (m, rad) and
/// stays readable (17 would print 0.001 as 0.0010000000000000002).
constexpr int kDigits = 12;

void yamlList(YAML::Emitter& yaml, const char* key, const double* v, int n) {
  yaml << YAML::Key << key << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (int i = 0; i < n; ++i) yaml << v[i];
  yaml << YAML::EndSeq;
}

void yamlBlock(YAML::Emitter& yaml, const std::string& name, const std::string& parent,
               const std::string& child, const Eigen::Isometry3d& T, const Matrix6d& cov,
               bool cov_known, const bool observable[6], bool estimated,
               const WeakDirection& weakest) {
  const Eigen::Quaterniond q(T.linear());
  const double xyzw[4] = {q.x(), q.y(), q.z(), q.w()};
  yaml << YAML::Key << name << YAML::Value << YAML::BeginMap;
  yaml << YAML::Key << "parent_frame" << YAML::Value << parent;
  yaml << YAML::Key << "child_frame" << YAML::Value << child;
  yaml << YAML::Key << "estimated" << YAML::Value << estimated;
  yamlList(yaml, "translation", T.translation().data(), 3);
  yamlList(yaml, "rotation_xyzw", xyzw, 4);
  // A solve that ended before its covariance has none (the topics' sigma -1): null here, and no
  // axis trusted, rather than the placeholder's numbers.
  yaml << YAML::Key << "covariance_known" << YAML::Value << cov_known;
  double sigma[6];
  bool trusted[6];
  for (int i = 0; i < 6; ++i) {
    sigma[i] = std::sqrt(cov(i, i)) * (i < 3 ? kDegPerRad : 1.0);
    // A given extrinsic constrains nothing from the data (as on the topics): no axis is trusted.
    trusted[i] = cov_known && estimated && observable[i];
  }
  if (cov_known) {
    yamlList(yaml, "sigma_rot_deg", sigma, 3);
    yamlList(yaml, "sigma_trans_m", sigma + 3, 3);
  } else {
    yaml << YAML::Key << "sigma_rot_deg" << YAML::Value << YAML::Null;
    yaml << YAML::Key << "sigma_trans_m" << YAML::Value << YAML::Null;
  }
  yaml << YAML::Key << "trusted_axes" << YAML::Value << YAML::Flow << YAML::BeginSeq;  // rx..tz
  for (bool t : trusted) yaml << t;
  yaml << YAML::EndSeq;
  if (!cov_known) {
    yaml << YAML::Key << "covariance_phi_tau" << YAML::Value << YAML::Null << YAML::EndMap;
    return;
  }
  const Eigen::Matrix<double, 6, 6, Eigen::RowMajor> cov_rows = cov;
  yamlList(yaml, "covariance_phi_tau", cov_rows.data(), 36);
  if (weakest.ratio > 0) {  // what the window constrained least, in trust-limit units
    yaml << YAML::Key << "weakest_direction" << YAML::Value << YAML::BeginMap;
    yaml << YAML::Key << "ratio_to_trust_limit" << YAML::Value << weakest.ratio;
    yaml << YAML::Key << "in_words" << YAML::Value << YAML::DoubleQuoted
         << describeDirection(weakest.direction);
    yamlList(yaml, "direction_scaled_phi_tau", weakest.direction.data(), 6);
    yaml << YAML::EndMap;
  }
  yaml << YAML::EndMap;
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
  YAML::Emitter yaml;
  yaml.SetDoublePrecision(kDigits);
  yaml.SetNullFormat(YAML::LowerNull);
  yaml << YAML::Comment("tescalib calibration (T_a_b maps points from b into a; covariance over")
       << YAML::Newline
       << YAML::Comment(
              "[phi_x phi_y phi_z tau_x tau_y tau_z] in rad and m, R = Exp(phi) R_est, "
              "t = t_est + tau)")
       << YAML::Newline;
  char stamp[64];
  std::snprintf(stamp, sizeof stamp, "%.9f", e.stamp);  // seconds since 1970 to the nanosecond
  yaml << YAML::BeginMap << YAML::Key << "converged" << YAML::Value << e.converged;
  yaml << YAML::Key << "keyframes_used" << YAML::Value << e.keyframes_used;
  yaml << YAML::Key << "windows_averaged" << YAML::Value << e.windows_averaged;
  yaml << YAML::Key << "stamp" << YAML::Value << stamp;
  yamlBlock(yaml, "T_cam_lidar", frames.left, frames.lidar, e.T_cam_lidar, e.cov_lidar,
            e.cov_lidar_known, e.observable_lidar, true, e.weakest_lidar);
  yamlBlock(yaml, "T_right_left", frames.right, frames.left, e.T_right_left, e.cov_stereo,
            e.cov_stereo_known, e.observable_stereo, e.stereo_estimated,
            e.stereo_estimated ? e.weakest_stereo : WeakDirection());
  yaml << YAML::EndMap;
  return std::string(yaml.c_str()) + "\n";
}

namespace {

/// The `n` numbers of the list `key` of `block`; throws DataError naming the entry.
std::vector<double> yamlNumbers(const YAML::Node& block, const std::string& name, const char* key,
                                size_t n) {
  const YAML::Node list = block[key];
  if (!list.IsDefined() || !list.IsSequence() || list.size() != n)
    throw DataError(name + "." + key + ": expected a list of " + std::to_string(n) + " numbers");
  std::vector<double> v;
  for (const YAML::Node& x : list) v.push_back(x.as<double>());
  return v;
}

/// One extrinsic's block: its transform, frames and covariance (when known).
void readYamlBlock(const YAML::Node& root, const std::string& name, Eigen::Isometry3d* T,
                   std::string* parent, std::string* child, Matrix6d* cov, bool* cov_known,
                   bool* estimated) {
  const YAML::Node block = root[name];
  if (!block.IsDefined() || !block.IsMap()) throw DataError("no " + name + " entry");
  *parent = block["parent_frame"].as<std::string>("");
  *child = block["child_frame"].as<std::string>("");
  *estimated = block["estimated"].as<bool>(true);
  const std::vector<double> t = yamlNumbers(block, name, "translation", 3);
  const std::vector<double> q = yamlNumbers(block, name, "rotation_xyzw", 4);
  const Eigen::Quaterniond quat(q[3], q[0], q[1], q[2]);
  if (!std::isfinite(quat.norm()) || std::fabs(quat.norm() - 1.0) > 1e-6)
    throw DataError(name + ".rotation_xyzw is not a unit quaternion");
  T->setIdentity();
  T->linear() = quat.normalized().toRotationMatrix();
  T->translation() = Eigen::Vector3d(t[0], t[1], t[2]);
  const YAML::Node cov_list = block["covariance_phi_tau"];
  *cov_known =
      block["covariance_known"].as<bool>(false) && cov_list.IsDefined() && !cov_list.IsNull();
  cov->setZero();
  if (!*cov_known) return;
  const std::vector<double> c = yamlNumbers(block, name, "covariance_phi_tau", 36);
  for (int i = 0; i < 36; ++i) (*cov)(i / 6, i % 6) = c[i];
}

}  // namespace

CalibrationFile readCalibrationYaml(const std::string& path) {
  CalibrationFile f;
  try {
    const YAML::Node root = YAML::LoadFile(path);
    f.converged = root["converged"].as<bool>(false);
    f.stamp = root["stamp"].as<double>(0.0);
    readYamlBlock(root, "T_cam_lidar", &f.T_cam_lidar, &f.frames.left, &f.frames.lidar,
                  &f.cov_lidar, &f.cov_lidar_known, &f.stereo_estimated);
    readYamlBlock(root, "T_right_left", &f.T_right_left, &f.frames.right, &f.frames.left,
                  &f.cov_stereo, &f.cov_stereo_known, &f.stereo_estimated);
  } catch (const YAML::Exception& e) {
    throw DataError(path + ": not a tescalib result file: " + e.what());
  } catch (const DataError& e) {
    throw DataError(path + ": " + e.what());
  }
  return f;
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
