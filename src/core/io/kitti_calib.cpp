#include "tescalib/core/io/kitti_calib.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>

#include "tescalib/core/common/error.h"
#include "tescalib/core/common/geometry.h"

namespace fs = std::filesystem;

namespace tescalib {
namespace {

std::map<std::string, std::vector<double>> readKeyValueFile(const std::string& path,
                                                            bool numeric_only_keys = false) {
  std::ifstream in(path);
  if (!in) throw DataError(path + ": cannot open calibration file");
  std::map<std::string, std::vector<double>> out;
  std::string line;
  while (std::getline(in, line)) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::string key = line.substr(0, colon);
    key.erase(std::remove_if(key.begin(), key.end(), ::isspace), key.end());
    std::istringstream values(line.substr(colon + 1));
    std::vector<double> v;
    std::string tok;
    bool numeric = true;
    while (values >> tok) {
      try {
        size_t used = 0;
        v.push_back(std::stod(tok, &used));
        if (used != tok.size()) numeric = false;
      } catch (const std::exception&) {
        numeric = false;
      }
    }
    if (!numeric && numeric_only_keys) continue;
    if (numeric) out[key] = v;
  }
  return out;
}

Eigen::Matrix<double, 3, 4> matrix3x4(const std::map<std::string, std::vector<double>>& kv,
                                      const std::string& key, const std::string& path) {
  const auto it = kv.find(key);
  if (it == kv.end()) throw DataError(path + ": missing key '" + key + "'");
  if (it->second.size() != 12)
    throw DataError(path + ": key '" + key + "' has " + std::to_string(it->second.size()) +
                    " values, expected 12 (a 3x4 matrix)");
  Eigen::Matrix<double, 3, 4> M;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) M(r, c) = it->second[4 * r + c];
  if (!M.allFinite()) throw DataError(path + ": key '" + key + "' has non-finite values");
  return M;
}

CameraIntrinsics intrinsicsFromP(const Eigen::Matrix<double, 3, 4>& P) {
  CameraIntrinsics c;
  c.fx = P(0, 0);
  c.fy = P(1, 1);
  c.cx = P(0, 2);
  c.cy = P(1, 2);
  return c;
}

}  // namespace

KittiOdometryCalib readKittiOdometryCalib(const std::string& path) {
  if (!fs::exists(path)) throw DataError(path + ": calibration file not found");
  const auto kv = readKeyValueFile(path);
  KittiOdometryCalib c;
  for (int i = 2; i < 4; ++i) c.P[i] = matrix3x4(kv, "P" + std::to_string(i), path);
  // The grey cameras' P0 / P1 are not used: a file with only P2, P3 and Tr (a hand-written
  // --init) is read, with P0 / P1 taken as P2 / P3.
  for (int i = 0; i < 2; ++i)
    c.P[i] = kv.count("P" + std::to_string(i)) ? matrix3x4(kv, "P" + std::to_string(i), path)
                                               : c.P[i + 2];
  c.Tr = matrix3x4(kv, "Tr", path);
  if (const auto r = kv.find("R_right_left"); r != kv.end()) {
    if (r->second.size() != 9)
      throw DataError(path + ": key 'R_right_left' has " + std::to_string(r->second.size()) +
                      " values, expected 9 (a 3x3 rotation)");
    for (int i = 0; i < 9; ++i) c.R_right_left(i / 3, i % 3) = r->second[i];
    if (!c.R_right_left.allFinite() ||
        !(c.R_right_left * c.R_right_left.transpose()).isIdentity(1e-6))
      throw DataError(path + ": key 'R_right_left' is not a rotation");
  }
  if (c.P[2](0, 0) <= 0 || c.P[3](0, 0) <= 0)
    throw DataError(path + ": P2/P3 have a non-positive focal length");
  return c;
}

std::string kittiOdometryCalibText(const KittiOdometryCalib& calib) {
  std::ostringstream out;
  out << std::setprecision(12);
  auto row = [&out](const std::string& key, const Eigen::Matrix<double, 3, 4>& M) {
    out << key << ":";
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) out << " " << M(r, c);
    out << "\n";
  };
  for (int i = 0; i < 4; ++i) row("P" + std::to_string(i), calib.P[i]);
  row("Tr", calib.Tr);
  if (!calib.R_right_left.isIdentity(1e-12)) {
    out << "R_right_left:";
    for (int i = 0; i < 9; ++i) out << " " << calib.R_right_left(i / 3, i % 3);
    out << "\n";
  }
  return out.str();
}

void writeKittiOdometryCalib(const std::string& path, const KittiOdometryCalib& calib) {
  std::ofstream out(path);
  if (!out || !(out << kittiOdometryCalibText(calib)))
    throw DataError(path + ": cannot write calibration file");
}

StereoRig rigFromOdometryCalib(const KittiOdometryCalib& calib) {
  StereoRig rig;
  rig.left = intrinsicsFromP(calib.P[2]);
  rig.right = intrinsicsFromP(calib.P[3]);
  const Eigen::Matrix3d K = calib.P[2].leftCols<3>();
  const Eigen::Matrix3d K_inv = K.inverse();
  Eigen::Isometry3d T_cam2_cam0 = Eigen::Isometry3d::Identity();
  T_cam2_cam0.translation() = K_inv * calib.P[2].col(3);
  Eigen::Isometry3d T_cam0_velo = Eigen::Isometry3d::Identity();
  T_cam0_velo.linear() = calib.Tr.leftCols<3>();
  T_cam0_velo.translation() = calib.Tr.col(3);
  rig.T_cam_lidar = T_cam2_cam0 * T_cam0_velo;
  // Re-orthonormalise (calib.txt has 6-7 significant digits).
  rig.T_cam_lidar.linear() =
      Eigen::Quaterniond(rig.T_cam_lidar.linear()).normalized().toRotationMatrix();
  // Each P = K [I | t]: the cameras' positions K^-1 P[:,3] (each with its own K), and the
  // rotation a rectified pair does not have (identity unless tescalib wrote R_right_left).
  rig.T_right_left = Eigen::Isometry3d::Identity();
  rig.T_right_left.linear() = calib.R_right_left;
  rig.T_right_left.translation() =
      calib.P[3].leftCols<3>().inverse() * calib.P[3].col(3) - K_inv * calib.P[2].col(3);
  return rig;
}

/// A calibration the solvers can start from, or a DataError naming what is wrong with it: the
/// cameras' focal lengths, the LiDAR extrinsic (Tr; all zeros or NaN would be "re-orthonormalised"
/// into some rotation) and the stereo baseline.
void checkKittiRig(const StereoRig& rig, const KittiOdometryCalib& calib, const std::string& path) {
  if (!(rig.left.fx > 0 && rig.left.fy > 0 && rig.right.fx > 0 && rig.right.fy > 0))
    throw DataError(path + ": P2/P3 need positive focal lengths fx and fy");
  // Orthonormal within the files' 6-7 digits (a shear of determinant 1 was re-orthonormalised
  // into some other rotation).
  const Eigen::Matrix3d R = calib.Tr.leftCols<3>();
  if (!calib.Tr.allFinite() || (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-3 ||
      std::fabs(R.determinant() - 1.0) > 0.01 || !isRigidTransform(rig.T_cam_lidar))
    throw DataError(path + ": the LiDAR extrinsic (Tr, or R_rect_00 R | T) is not a rotation");
  // P = K [I | t] with K upper triangular, no skew, and a last row (0 0 1 tz): anything else
  // would be ignored by the intrinsics read from it.
  for (int c : {2, 3}) {
    const auto& P = calib.P[c];
    if (std::fabs(P(0, 1)) > 1e-6 * std::fabs(P(0, 0)) || P(1, 0) != 0.0 || P(2, 0) != 0.0 ||
        P(2, 1) != 0.0 || std::fabs(P(2, 2) - 1.0) > 1e-9)
      throw DataError(path + ": P" + std::to_string(c) +
                      " is not a rectified camera's K [I | t] (skew, or a last row other than "
                      "0 0 1 tz)");
  }
  const std::string pair = stereoExtrinsicProblem(rig.T_right_left);
  if (!pair.empty()) throw DataError(path + ": P2/P3: " + pair);
}

StereoRig readCheckedOdometryRig(const std::string& path) {
  const KittiOdometryCalib calib = readKittiOdometryCalib(path);
  const StereoRig rig = rigFromOdometryCalib(calib);
  checkKittiRig(rig, calib, path);
  return rig;
}

KittiOdometryCalib readKittiRawCalib(const std::string& c2c, const std::string& v2c, int* width,
                                     int* height) {
  const auto cam = readKeyValueFile(c2c, true);
  const auto velo = readKeyValueFile(v2c, true);
  KittiOdometryCalib calib;
  calib.P[0] = matrix3x4(cam, "P_rect_00", c2c);
  calib.P[1] = matrix3x4(cam, "P_rect_01", c2c);
  calib.P[2] = matrix3x4(cam, "P_rect_02", c2c);
  calib.P[3] = matrix3x4(cam, "P_rect_03", c2c);
  const auto r_rect = cam.find("R_rect_00");
  if (r_rect == cam.end() || r_rect->second.size() != 9)
    throw DataError(c2c + ": missing or malformed key 'R_rect_00' (expected 9 values)");
  const auto R = velo.find("R");
  const auto T = velo.find("T");
  if (R == velo.end() || R->second.size() != 9)
    throw DataError(v2c + ": missing or malformed key 'R' (expected 9 values)");
  if (T == velo.end() || T->second.size() != 3)
    throw DataError(v2c + ": missing or malformed key 'T' (expected 3 values)");
  Eigen::Matrix4d rect = Eigen::Matrix4d::Identity();
  Eigen::Matrix4d velo_to_cam0 = Eigen::Matrix4d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      rect(r, c) = r_rect->second[3 * r + c];
      velo_to_cam0(r, c) = R->second[3 * r + c];
    }
    velo_to_cam0(r, 3) = T->second[r];
  }
  calib.Tr = (rect * velo_to_cam0).topRows<3>();  // velodyne -> rectified cam0
  *width = *height = 0;
  const auto size = cam.find("S_rect_02");
  if (size != cam.end() && size->second.size() == 2) {
    *width = static_cast<int>(size->second[0]);
    *height = static_cast<int>(size->second[1]);
  }
  return calib;
}

}  // namespace tescalib
