#include "tescalib/core/io/kitti_reader.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "tescalib/core/common/error.h"
#include "tescalib/core/common/geometry.h"
#include "tescalib/core/io/sim_info.h"

namespace fs = std::filesystem;

namespace tescalib {
namespace {

/// Reads "key: v1 v2 ..." lines into a map. Keys keep their name without the colon.
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
  checkKittiRig(rig_, calib_, (d / "calib.txt").string());
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
  int width = 0, height = 0;
  KittiOdometryCalib calib = readKittiRawCalib(c2c, v2c, &width, &height);
  calib_ = calib;
  rig_ = rigFromOdometryCalib(calib);
  checkKittiRig(rig_, calib, c2c + " / " + v2c);
  if (width > 0) {
    rig_.left.width = rig_.right.width = width;
    rig_.left.height = rig_.right.height = height;
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
  if (!fs::exists(fs::path(dir_) / "sim_info.txt")) return layout_ == KittiLayout::kRaw;
  const auto info = readSimInfo(dir_);
  const auto swept = info.find("lidar_sweep");
  if (swept == info.end()) return false;
  if (swept->second != "0" && swept->second != "1")
    throw DataError((fs::path(dir_) / "sim_info.txt").string() +
                    ": 'lidar_sweep:' is not followed by 0 or 1");
  return swept->second == "1";
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
