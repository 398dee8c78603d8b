#include "tescalib/core/sim/sensor_realism.h"

#include <cmath>
#include <iomanip>
#include <sstream>
#include <utility>

#include "tescalib/core/sim/simulator_random.h"

namespace tescalib {
namespace sim {
namespace {

constexpr double kRadPerDeg = M_PI / 180.0;

using Field = double RealismSizes::*;

/// Every size by its key, in sim_info.txt's order.
const std::pair<const char*, Field> kFields[] = {
    {"right_rotation_deg", &RealismSizes::right_rotation_deg},
    {"baseline_scale", &RealismSizes::baseline_scale},
    {"lens_k1", &RealismSizes::lens_k1},
    {"right_blur_px", &RealismSizes::right_blur_px},
    {"vignetting", &RealismSizes::vignetting},
    {"laser_range_offset_m", &RealismSizes::laser_range_offset_m},
    {"laser_elevation_deg", &RealismSizes::laser_elevation_deg},
    {"range_scale", &RealismSizes::range_scale},
    {"mixed_pixel_fraction", &RealismSizes::mixed_pixel_fraction},
    {"lidar_time_offset_s", &RealismSizes::lidar_time_offset_s},
    {"asphalt_texture", &RealismSizes::asphalt_texture},
};

bool validValue(const std::string& key, double v) {
  if (!std::isfinite(v)) return false;
  if (key == "asphalt_texture") return v >= 0 && v <= 1;
  if (key == "mixed_pixel_fraction") return v >= 0 && v <= 1;
  if (key == "right_rotation_deg" || key == "laser_elevation_deg") return v >= 0 && v <= 1;
  if (key == "baseline_scale" || key == "range_scale" || key == "lens_k1")
    return v >= 0 && v <= 0.1;
  if (key == "lidar_time_offset_s") return v >= 0 && v <= 0.1;
  return v >= 0 && v <= 10;  // blur px, vignetting, range offsets m
}

std::string listYaml(const std::vector<double>& values, double scale) {
  std::ostringstream s;
  s << std::setprecision(6) << "[";
  for (size_t i = 0; i < values.size(); ++i) s << (i ? ", " : "") << values[i] * scale;
  s << "]";
  return s.str();
}

}  // namespace

bool RealismSizes::preset(const std::string& name, RealismSizes* sizes) {
  if (name == "none") {
    *sizes = RealismSizes{};
    return true;
  }
  if (name != "kitti") return false;
  RealismSizes k;
  k.right_rotation_deg = 0.01;
  k.baseline_scale = 0.012;
  k.lens_k1 = 0.008;
  k.right_blur_px = 0.5;
  k.vignetting = 0.15;
  k.laser_range_offset_m = 0.03;
  k.laser_elevation_deg = 0.1;
  k.range_scale = 0.003;
  k.mixed_pixel_fraction = 0.5;
  k.lidar_time_offset_s = 0.001;
  k.asphalt_texture = 0.75;
  *sizes = k;
  return true;
}

std::string RealismSizes::set(const std::string& assignments) {
  std::stringstream in(assignments);
  for (std::string item; std::getline(in, item, ',');) {
    const auto eq = item.find('=');
    const std::string key = item.substr(0, eq);
    Field field = nullptr;
    for (const auto& [name, f] : kFields)
      if (key == name) field = f;
    if (eq == std::string::npos || !field) {
      std::string keys;
      for (const auto& kv : kFields) keys += std::string(keys.empty() ? "" : ", ") + kv.first;
      return "'" + item + "' is not KEY=VALUE with KEY one of " + keys;
    }
    const std::string text = item.substr(eq + 1);
    size_t used = 0;
    double v = 0;
    try {
      v = std::stod(text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (text.empty() || used != text.size() || !validValue(key, v))
      return "'" + item + "': the value is not a number in " + key + "'s range";
    this->*field = v;
  }
  return "";
}

bool RealismSizes::none() const {
  for (const auto& [name, f] : kFields)
    if (this->*f != RealismSizes{}.*f) return false;
  return true;
}

std::string RealismSizes::yaml() const {
  std::ostringstream s;
  s << std::setprecision(10);
  for (const auto& [name, f] : kFields) s << "realism_size_" << name << ": " << this->*f << "\n";
  return s.str();
}

bool RealismDraw::movesRightCamera() const {
  return !right_rotation.isIdentity(0) || baseline_scale != 1;
}

Eigen::Isometry3d RealismDraw::trueRightLeft(const Eigen::Isometry3d& nominal) const {
  Eigen::Isometry3d T = nominal;
  T.linear() = right_rotation * nominal.linear();
  T.translation() = right_rotation * (baseline_scale * nominal.translation());
  return T;
}

std::string RealismDraw::yaml() const {
  std::ostringstream s;
  const Eigen::AngleAxisd aa(right_rotation);
  const Eigen::Vector3d r = aa.angle() * aa.axis() / kRadPerDeg;
  s << std::setprecision(8) << "realism_right_rotation_deg: [" << r.x() << ", " << r.y() << ", "
    << r.z() << "]\n"
    << "realism_baseline_scale: " << baseline_scale << "\n"
    << "realism_lens_k1: " << lens_k1 << "\n"
    << "realism_right_blur_px: " << right_blur_px << "\n"
    << "realism_vignetting_left_right: [" << left_vignetting << ", " << right_vignetting << "]\n"
    << "realism_laser_range_offset_m: " << listYaml(laser_range_offset_m, 1) << "\n"
    << "realism_laser_elevation_deg: " << listYaml(laser_elevation_rad, 1 / kRadPerDeg) << "\n"
    << "realism_range_scale: " << range_scale << "\n"
    << "realism_mixed_pixel_fraction: " << mixed_pixel_fraction << "\n"
    << "realism_lidar_time_offset_s: " << lidar_time_offset_s << "\n"
    << "realism_asphalt_texture: " << asphalt_texture << "\n";
  return s.str();
}

RealismDraw drawRealism(const RealismSizes& sizes, uint64_t seed, int rings) {
  SimRandom rng(subSeed(seed, 0x4ea1));
  RealismDraw d;
  const auto magnitude = [&rng](double size) { return size * rng.uniform(0.5, 1.5); };
  Eigen::Vector3d w;
  for (int i = 0; i < 3; ++i) w[i] = sizes.right_rotation_deg * kRadPerDeg * rng.normal();
  if (w.norm() > 0) d.right_rotation = Eigen::AngleAxisd(w.norm(), w.normalized()).matrix();
  d.baseline_scale = 1 + sizes.baseline_scale * rng.normal();
  d.lens_k1 = sizes.lens_k1 * rng.normal();
  d.right_blur_px = magnitude(sizes.right_blur_px);
  d.left_vignetting = magnitude(sizes.vignetting);
  d.right_vignetting = magnitude(sizes.vignetting);
  d.laser_range_offset_m.resize(rings);
  d.laser_elevation_rad.resize(rings);
  for (int r = 0; r < rings; ++r) {
    d.laser_range_offset_m[r] = sizes.laser_range_offset_m * rng.normal();
    d.laser_elevation_rad[r] = sizes.laser_elevation_deg * kRadPerDeg * rng.normal();
  }
  d.range_scale = 1 + sizes.range_scale * rng.normal();
  d.mixed_pixel_fraction = sizes.mixed_pixel_fraction;
  d.lidar_time_offset_s = sizes.lidar_time_offset_s * rng.normal();
  d.asphalt_texture = sizes.asphalt_texture;
  return d;
}

}  // namespace sim
}  // namespace tescalib
