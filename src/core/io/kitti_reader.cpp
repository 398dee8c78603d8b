#include "tescalib/core/io/kitti_reader.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <numeric>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "tescalib/core/common/error.h"
#include "tescalib/core/common/geometry.h"

namespace fs = std::filesystem;

namespace tescalib {
namespace {

/// Reads "key: v1 v2 ..." lines into a map. Keys keep their name without the colon.
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

std::string numbered(const fs::path& folder, int id, int digits, const std::string& ext) {
  std::ostringstream name;
  name << std::setw(digits) << std::setfill('0') << id << ext;
  return (folder / name.str()).string();
}

/// Frame numbers of files named NNNN<ext> in a folder, all of one width (`*digits`, kept when
/// the folder has none); a DataError for names of mixed widths (1.png beside 000002.png), which
/// the frames' paths, rebuilt from the number and one width, would miss.
std::vector<int> listNumbered(const fs::path& folder, const std::string& ext, int* digits) {
  std::vector<int> ids;
  if (!fs::is_directory(folder)) return ids;
  int width = 0;
  std::string first;
  for (const auto& e : fs::directory_iterator(folder)) {
    const std::string stem = e.path().stem().string();
    if (e.path().extension() != ext || stem.empty() ||
        !std::all_of(stem.begin(), stem.end(), ::isdigit))
      continue;
    const size_t first_nonzero = stem.find_first_not_of('0');
    if (first_nonzero != std::string::npos && stem.size() - first_nonzero > 9)
      throw DataError(e.path().string() +
                      ": frame number out of range (KITTI numbers frames from 0 with 6 or 10 "
                      "zero-padded digits)");
    if (width && static_cast<int>(stem.size()) != width)
      throw DataError(folder.string() + ": frame numbers of different widths (" + first + " and " +
                      e.path().filename().string() +
                      "): KITTI pads every frame number to one width (6 or 10 digits)");
    if (!width) width = static_cast<int>(stem.size()), first = e.path().filename().string();
    ids.push_back(std::stoi(stem));
  }
  if (width) *digits = width;
  std::sort(ids.begin(), ids.end());
  return ids;
}

std::vector<int> intersect(const std::vector<int>& a, const std::vector<int>& b) {
  std::vector<int> out;
  std::set_intersection(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(out));
  return out;
}

/// listNumbered for the three folders of a sequence, which must share one width.
/// `counts`: the files found in each.
std::vector<int> listFrames(const std::array<fs::path, 3>& folders,
                            const std::array<std::string, 3>& exts, int* digits,
                            std::array<size_t, 3>* counts) {
  std::vector<int> ids[3];
  int widths[3];
  for (int k = 0; k < 3; ++k) {
    widths[k] = 0;
    ids[k] = listNumbered(folders[k], exts[k], &widths[k]);
    (*counts)[k] = ids[k].size();
  }
  int width = 0, from = 0;
  for (int k = 0; k < 3; ++k) {
    if (!widths[k]) continue;
    if (width && widths[k] != width)
      throw DataError(folders[k].string() + ": its frame numbers are " + std::to_string(widths[k]) +
                      " digits wide, " + folders[from].string() + "'s " + std::to_string(width) +
                      ": one width for all three folders");
    if (!width) width = widths[k], from = k;
  }
  if (width) *digits = width;
  return intersect(intersect(ids[0], ids[1]), ids[2]);
}

/// "2011-09-26 13:02:25.964389445" -> seconds since the epoch (UTC).
double parseRawTimestamp(const std::string& s, const std::string& path, int line) {
  std::tm tm{};
  int nanos_digits = 0;
  double frac = 0;
  const auto dot = s.find('.');
  std::istringstream in(s.substr(0, dot));
  in >> std::get_time(&tm, "%Y-%m-%d %H:%M:%S");
  const bool parsed = !in.fail();
  std::string rest;
  if (parsed) std::getline(in, rest);  // nothing but blanks may follow the seconds
  if (!parsed || rest.find_first_not_of(" \t\r") != std::string::npos)
    throw DataError(path + ":" + std::to_string(line) + ": malformed timestamp '" + s + "'");
  if (dot != std::string::npos) {
    std::string f = s.substr(dot + 1);
    while (!f.empty() && ::isspace(static_cast<unsigned char>(f.back()))) f.pop_back();
    if (f.size() > 12 || !std::all_of(f.begin(), f.end(), ::isdigit))
      throw DataError(path + ":" + std::to_string(line) + ": malformed fraction of a second in '" +
                      s + "'");
    nanos_digits = static_cast<int>(f.size());
    if (nanos_digits > 0) frac = std::stod(f) / std::pow(10.0, nanos_digits);
  }
  return static_cast<double>(timegm(&tm)) + frac;
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

namespace {
/// A calibration the solvers can start from, or a DataError naming what is wrong with it: the
/// cameras' focal lengths, the LiDAR extrinsic (Tr; all zeros or NaN would be "re-orthonormalised"
/// into some rotation) and the stereo baseline.
void checkRig(const StereoRig& rig, const KittiOdometryCalib& calib, const std::string& path) {
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
}  // namespace

StereoRig readCheckedOdometryRig(const std::string& path) {
  const KittiOdometryCalib calib = readKittiOdometryCalib(path);
  const StereoRig rig = rigFromOdometryCalib(calib);
  checkRig(rig, calib, path);
  return rig;
}

LidarScan readVelodyneBin(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw DataError(path + ": cannot open LiDAR scan");
  const std::streamsize bytes = in.tellg();
  if (bytes % 16 != 0)
    throw DataError(path + ": truncated LiDAR scan (" + std::to_string(bytes) +
                    " bytes is not a multiple of 16 = 4 float32 per point)");
  if (bytes == 0) throw DataError(path + ": empty LiDAR scan");
  in.seekg(0);
  std::vector<float> raw(static_cast<size_t>(bytes / 4));
  in.read(reinterpret_cast<char*>(raw.data()), bytes);
  LidarScan scan(raw.size() / 4);
  for (size_t i = 0; i < scan.size(); ++i) {
    scan[i].x = raw[4 * i];
    scan[i].y = raw[4 * i + 1];
    scan[i].z = raw[4 * i + 2];
    scan[i].intensity = raw[4 * i + 3];
  }
  recoverRings(scan);
  return scan;
}

void writeVelodyneBin(const std::string& path, const LidarScan& scan) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw DataError(path + ": cannot write LiDAR scan");
  std::vector<float> raw(scan.size() * 4);
  for (size_t i = 0; i < scan.size(); ++i) {
    raw[4 * i] = scan[i].x;
    raw[4 * i + 1] = scan[i].y;
    raw[4 * i + 2] = scan[i].z;
    raw[4 * i + 3] = scan[i].intensity;
  }
  out.write(reinterpret_cast<const char*>(raw.data()),
            static_cast<std::streamsize>(raw.size() * 4));
}

int recoverRings(LidarScan& scan) {
  if (scan.empty()) return 0;
  // KITTI stores each laser's revolution in turn, starting and ending facing forward (azimuth 0),
  // so a new ring starts where the azimuth crosses 0 in the sweep direction. (The wrap at +-180
  // deg lies inside a ring.) The sweep direction is taken from the data: the median step.
  std::vector<float> az(scan.size());
  for (size_t i = 0; i < scan.size(); ++i) az[i] = std::atan2(scan[i].y, scan[i].x);
  std::vector<float> steps;
  steps.reserve(scan.size() / 8 + 1);
  for (size_t i = 8; i < scan.size(); i += 8) {
    float d = az[i] - az[i - 8];
    if (d > float(M_PI)) d -= float(2 * M_PI);
    if (d < -float(M_PI)) d += float(2 * M_PI);
    steps.push_back(d);
  }
  float direction = 1.f;
  if (!steps.empty()) {
    std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
    direction = steps[steps.size() / 2] < 0 ? -1.f : 1.f;
  }
  constexpr size_t kMinRingPoints = 50;  // jitter around azimuth 0 must not split a ring
  std::vector<size_t> starts{0};
  for (size_t i = 1; i < scan.size(); ++i) {
    const float prev = direction * az[i - 1];
    const float cur = direction * az[i];
    const bool crosses_forward =
        prev < 0.f && prev > -float(M_PI_2) && cur >= 0.f && cur < float(M_PI_2);
    if (crosses_forward && i - starts.back() >= kMinRingPoints) starts.push_back(i);
  }
  starts.push_back(scan.size());
  const int n = static_cast<int>(starts.size()) - 1;
  // Order segments by mean elevation so that ring 0 is the lowest beam.
  std::vector<double> elevation(n, 0.0);
  for (int s = 0; s < n; ++s) {
    double sum = 0;
    for (size_t i = starts[s]; i < starts[s + 1]; ++i) {
      const auto& p = scan[i];
      sum += std::atan2(p.z, std::hypot(p.x, p.y));
    }
    elevation[s] = sum / static_cast<double>(starts[s + 1] - starts[s]);
  }
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return elevation[a] < elevation[b]; });
  std::vector<int> ring_of_segment(n);
  for (int r = 0; r < n; ++r) ring_of_segment[order[r]] = r;
  for (int s = 0; s < n; ++s)
    for (size_t i = starts[s]; i < starts[s + 1]; ++i)
      scan[i].ring = static_cast<uint16_t>(ring_of_segment[s]);
  return n;
}

namespace {
/// "a/b/" and "a/b/." -> "a/b": the raw layout looks for its calibration in the parent folder.
std::string withoutTrailingSeparator(const std::string& dir) {
  fs::path p = fs::path(dir).lexically_normal();
  if (p.filename().empty() && p.has_parent_path() && p != p.root_path()) p = p.parent_path();
  return p.string();
}
}  // namespace

KittiSequence::KittiSequence(const std::string& dir) : dir_(withoutTrailingSeparator(dir)) {
  if (!fs::is_directory(dir)) throw DataError(dir + ": sequence folder not found");
  if (fs::exists(fs::path(dir) / "calib.txt") || fs::is_directory(fs::path(dir) / "image_2")) {
    layout_ = KittiLayout::kOdometry;
    openOdometry();
  } else if (fs::is_directory(fs::path(dir) / "image_02")) {
    layout_ = KittiLayout::kRaw;
    openRaw();
  } else {
    throw DataError(dir +
                    ": neither a KITTI odometry sequence (calib.txt, image_2/) nor a KITTI "
                    "raw drive (image_02/data/)");
  }
  if (frame_ids_.empty())
    throw DataError(dir +
                    ": no frames (no frame has a left image, a right image and a LiDAR scan)");
  checkImageSizes();
}

void KittiSequence::openOdometry() {
  const fs::path d(dir_);
  calib_ = readKittiOdometryCalib((d / "calib.txt").string());
  rig_ = rigFromOdometryCalib(calib_);
  checkRig(rig_, calib_, (d / "calib.txt").string());
  int digits = 6;
  std::array<size_t, 3> found;
  const auto ids = listFrames({d / "image_2", d / "image_3", d / "velodyne"},
                              {".png", ".png", ".bin"}, &digits, &found);
  name_digits_ = digits;
  const std::string times_path = (d / "times.txt").string();
  std::ifstream times(times_path);
  if (!times) throw DataError(times_path + ": cannot open timestamps");
  // One finite stamp per line, increasing; blank lines only at the end (a blank line in the
  // middle would give every later frame the next frame's stamp).
  std::vector<double> all;
  std::string line;
  int line_no = 0, blank_at = 0;
  while (std::getline(times, line)) {
    ++line_no;
    const std::string where = times_path + ":" + std::to_string(line_no) + ": ";
    if (line.find_first_not_of(" \t\r") == std::string::npos) {
      if (!blank_at) blank_at = line_no;
      continue;
    }
    if (blank_at)
      throw DataError(where + "a stamp after the blank line " + std::to_string(blank_at) +
                      " (one stamp per frame, frame n on line n + 1)");
    double t = 0;
    size_t used = 0;
    try {
      t = std::stod(line, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (!used || line.find_first_not_of(" \t\r", used) != std::string::npos || !std::isfinite(t))
      throw DataError(where + "malformed timestamp '" + line + "'");
    if (!all.empty() && !(t > all.back()))
      throw DataError(where + "the stamps do not increase (" + line + " after " +
                      std::to_string(all.back()) + ")");
    all.push_back(t);
  }
  for (int id : ids) {
    if (id >= static_cast<int>(all.size())) continue;  // a frame without a stamp is not usable
    frame_ids_.push_back(id);
    stamps_.push_back(all[id]);
  }
  noteIncomplete(found[0], found[1], found[2], ids.size());
}

void KittiSequence::openRaw() {
  const fs::path d(dir_);
  fs::path calib_dir = d;
  if (!fs::exists(d / "calib_cam_to_cam.txt")) calib_dir = d.parent_path();
  const std::string c2c = (calib_dir / "calib_cam_to_cam.txt").string();
  const std::string v2c = (calib_dir / "calib_velo_to_cam.txt").string();
  if (!fs::exists(c2c))
    throw DataError(c2c +
                    ": calibration file not found (looked in the drive folder and its parent)");
  if (!fs::exists(v2c))
    throw DataError(v2c +
                    ": calibration file not found (looked in the drive folder and its parent)");
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
  calib_ = calib;
  rig_ = rigFromOdometryCalib(calib);
  checkRig(rig_, calib, c2c + " / " + v2c);
  const auto size = cam.find("S_rect_02");
  if (size != cam.end() && size->second.size() == 2) {
    rig_.left.width = rig_.right.width = static_cast<int>(size->second[0]);
    rig_.left.height = rig_.right.height = static_cast<int>(size->second[1]);
  }
  int digits = 10;
  std::array<size_t, 3> found;
  const auto ids =
      listFrames({d / "image_02" / "data", d / "image_03" / "data", d / "velodyne_points" / "data"},
                 {".png", ".png", ".bin"}, &digits, &found);
  name_digits_ = digits;
  // Prefer the camera stamps (the images define the frame); fall back to the LiDAR's.
  std::string ts_path = (d / "image_02" / "timestamps.txt").string();
  if (!fs::exists(ts_path)) ts_path = (d / "velodyne_points" / "timestamps.txt").string();
  std::ifstream ts(ts_path);
  if (!ts) throw DataError(ts_path + ": cannot open timestamps");
  std::vector<double> all;
  std::string line;
  int line_no = 0;
  while (std::getline(ts, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    all.push_back(parseRawTimestamp(line, ts_path, line_no));
  }
  for (int id : ids) {
    if (id >= static_cast<int>(all.size())) continue;
    frame_ids_.push_back(id);
    stamps_.push_back(all[id]);
  }
  noteIncomplete(found[0], found[1], found[2], ids.size());
}

void KittiSequence::noteIncomplete(size_t left, size_t right, size_t scans, size_t complete) {
  const size_t unstamped = complete - frame_ids_.size();
  if (left == complete && right == complete && scans == complete && unstamped == 0) return;
  incomplete_ = std::to_string(left) + " left images, " + std::to_string(right) +
                " right images, " + std::to_string(scans) + " scans";
  if (unstamped)
    incomplete_ += "; " + std::to_string(unstamped) + (unstamped == 1 ? " frame" : " frames") +
                   " without a stamp";
}

void KittiSequence::checkImageSizes() {
  const cv::Mat first = cv::imread(leftPath(0), cv::IMREAD_UNCHANGED);
  if (first.empty()) throw DataError(leftPath(0) + ": cannot read image");
  if (rig_.left.width > 0 && (first.cols != rig_.left.width || first.rows != rig_.left.height))
    throw DataError(leftPath(0) + ": image is " + std::to_string(first.cols) + "x" +
                    std::to_string(first.rows) + ", calibration says " +
                    std::to_string(rig_.left.width) + "x" + std::to_string(rig_.left.height));
  rig_.left.width = rig_.right.width = first.cols;
  rig_.left.height = rig_.right.height = first.rows;
}

std::string KittiSequence::leftPath(size_t i) const {
  const fs::path d(dir_);
  return layout_ == KittiLayout::kOdometry
             ? numbered(d / "image_2", frame_ids_[i], name_digits_, ".png")
             : numbered(d / "image_02" / "data", frame_ids_[i], name_digits_, ".png");
}

std::string KittiSequence::rightPath(size_t i) const {
  const fs::path d(dir_);
  return layout_ == KittiLayout::kOdometry
             ? numbered(d / "image_3", frame_ids_[i], name_digits_, ".png")
             : numbered(d / "image_03" / "data", frame_ids_[i], name_digits_, ".png");
}

std::string KittiSequence::velodynePath(size_t i) const {
  const fs::path d(dir_);
  return layout_ == KittiLayout::kOdometry
             ? numbered(d / "velodyne", frame_ids_[i], name_digits_, ".bin")
             : numbered(d / "velodyne_points" / "data", frame_ids_[i], name_digits_, ".bin");
}

LidarScan KittiSequence::loadScan(size_t i) const { return readVelodyneBin(velodynePath(i)); }

Frame KittiSequence::load(size_t i) const {
  Frame f;
  f.index = frame_ids_[i];
  f.stamp = stamps_[i];
  f.scan = loadScan(i);
  auto readImage = [this](const std::string& path) {
    cv::Mat img = cv::imread(path, cv::IMREAD_COLOR);
    if (img.empty()) throw DataError(path + ": cannot read image");
    if (img.cols != rig_.left.width || img.rows != rig_.left.height)
      throw DataError(path + ": image is " + std::to_string(img.cols) + "x" +
                      std::to_string(img.rows) + ", expected " + std::to_string(rig_.left.width) +
                      "x" + std::to_string(rig_.left.height) + " like the rest of the sequence");
    return img;
  };
  f.left = readImage(leftPath(i));
  f.right = readImage(rightPath(i));
  return f;
}

bool KittiSequence::sweptScans() const {
  std::ifstream info(fs::path(dir_) / "sim_info.txt");
  if (!info) return layout_ == KittiLayout::kRaw;
  std::string line;
  while (std::getline(info, line))
    if (line.rfind("lidar_sweep:", 0) == 0) {
      std::istringstream value(line.substr(12));
      int swept = 0;
      if (!(value >> swept))
        throw DataError((fs::path(dir_) / "sim_info.txt").string() +
                        ": 'lidar_sweep:' is not followed by 0 or 1");
      return swept == 1;
    }
  return false;
}

std::vector<size_t> KittiSequence::keyframes(double min_dt) const {
  std::vector<size_t> out;
  for (size_t i = 0; i < size(); ++i)
    if (out.empty() || stamps_[i] - stamps_[out.back()] >= min_dt - 1e-6) out.push_back(i);
  return out;
}

std::vector<std::unique_ptr<KittiSequence>> openSequences(const std::vector<std::string>& dirs) {
  std::vector<std::unique_ptr<KittiSequence>> seqs;
  for (const auto& dir : dirs) {
    seqs.push_back(std::make_unique<KittiSequence>(dir));
    const StereoRig& a = seqs.front()->rig();
    const StereoRig& b = seqs.back()->rig();
    auto same = [](const CameraIntrinsics& p, const CameraIntrinsics& q) {
      return std::fabs(p.fx - q.fx) <= 1e-3 && std::fabs(p.fy - q.fy) <= 1e-3 &&
             std::fabs(p.cx - q.cx) <= 1e-3 && std::fabs(p.cy - q.cy) <= 1e-3;
    };
    if (poseError(a.T_cam_lidar, b.T_cam_lidar).norm() > 1e-4 ||
        poseError(a.T_right_left, b.T_right_left).norm() > 1e-4 || !same(a.left, b.left) ||
        !same(a.right, b.right))
      throw DataError(dir + ": calibration differs from " + dirs.front() +
                      " (a window must share one calibration)");
    if (a.left.width != b.left.width || a.left.height != b.left.height)
      throw DataError(dir + ": images of " + std::to_string(b.left.width) + "x" +
                      std::to_string(b.left.height) + ", " + dirs.front() + "'s are " +
                      std::to_string(a.left.width) + "x" + std::to_string(a.left.height) +
                      " (a window must share one camera)");
  }
  return seqs;
}

}  // namespace tescalib
