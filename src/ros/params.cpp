#include "tescalib/ros/params.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>

#include <ros/param.h>

#include "tescalib/core/stereo/stereo_cloud.h"

namespace tescalib {

namespace {
/// Whether a parameter server value can be read as T without losing anything: roscpp itself
/// rounds 10.7 to an int and keeps the default for "true" given to a bool, silently.
bool hasType(const XmlRpc::XmlRpcValue& v, bool*) {
  return v.getType() == XmlRpc::XmlRpcValue::TypeBoolean;
}
bool hasType(const XmlRpc::XmlRpcValue& v, int*) {
  return v.getType() == XmlRpc::XmlRpcValue::TypeInt;
}
bool hasType(const XmlRpc::XmlRpcValue& v, double*) {
  return v.getType() == XmlRpc::XmlRpcValue::TypeDouble ||
         v.getType() == XmlRpc::XmlRpcValue::TypeInt;
}
bool hasType(const XmlRpc::XmlRpcValue& v, std::string*) {
  return v.getType() == XmlRpc::XmlRpcValue::TypeString;
}
bool hasType(const XmlRpc::XmlRpcValue& v, std::vector<double>*) {
  if (v.getType() != XmlRpc::XmlRpcValue::TypeArray) return false;
  for (int i = 0; i < v.size(); ++i)
    if (!hasType(v[i], static_cast<double*>(nullptr))) return false;
  return true;
}
const char* typeName(bool*) { return "true or false"; }
const char* typeName(int*) { return "an integer"; }
const char* typeName(double*) { return "a number"; }
const char* typeName(std::string*) { return "a string"; }
const char* typeName(std::vector<double>*) { return "a list of numbers"; }

/// What a parameter server value is, for a message: `the string "true"`, `the number 10.7`.
std::string describe(XmlRpc::XmlRpcValue& v) {
  std::ostringstream o;
  switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeString:
      o << "the string \"" << static_cast<std::string&>(v) << "\"";
      break;
    case XmlRpc::XmlRpcValue::TypeDouble: {
      // 10.0 printed as "10" hid why an integer parameter refused it.
      const double d = static_cast<double&>(v);
      if (std::isfinite(d) && d == std::floor(d) && std::fabs(d) < 1e15)
        o << "the number " << std::fixed << std::setprecision(1) << d << " (a decimal)";
      else
        o << "the number " << d;
      break;
    }
    case XmlRpc::XmlRpcValue::TypeInt:
      o << "the integer " << static_cast<int&>(v);
      break;
    case XmlRpc::XmlRpcValue::TypeBoolean:
      o << (static_cast<bool&>(v) ? "true" : "false");
      break;
    case XmlRpc::XmlRpcValue::TypeArray:
      o << "a list of " << v.size();
      break;
    default:
      o << "a value of another type";
  }
  return o.str();
}

/// Reads private parameters, remembering every name it was asked for, so that the names on the
/// parameter server it never read (typos) can be reported, and every value of the wrong type.
struct Reader {
  const ros::NodeHandle& nh;
  std::set<std::string> names;
  std::ostringstream wrong_type;
  template <typename T>
  void operator()(const std::string& name, T* value) {
    names.insert(name);
    XmlRpc::XmlRpcValue raw;
    if (!nh.getParam(name, raw)) return;  // not set: the default stays
    if (!hasType(raw, value)) {
      wrong_type << name << " must be " << typeName(value) << " (got " << describe(raw) << "); ";
      return;
    }
    nh.getParam(name, *value);
  }
};

/// Collects every parameter's name and value as text, through the same functions that read
/// them: the loader and this list cannot name different parameters.
struct Collector {
  std::map<std::string, std::string> values;
  template <typename T>
  void operator()(const std::string& name, T* value) {
    std::ostringstream o;
    o << std::setprecision(17) << *value;
    values[name] = o.str();
  }
  void operator()(const std::string& name, std::vector<double>* value) {
    std::ostringstream o;
    o << std::setprecision(17);
    for (double v : *value) o << v << " ";
    values[name] = o.str();
  }
};

/// The rounds of a disparity refinement read from `prefix`refine_iterations and
/// `prefix`refine_smoothed_rounds.
void checkRefinementRounds(const DisparityRefinementSettings& r, const std::string& prefix,
                           std::ostringstream& e) {
  if (r.iterations < 0 || r.iterations > 5)
    e << prefix << "refine_iterations must be between 0 and 5 (got " << r.iterations << "); ";
  if (r.smoothed_gradient_rounds < 0 || r.smoothed_gradient_rounds > r.iterations)
    e << prefix << "refine_smoothed_rounds must be between 0 and " << prefix
      << "refine_iterations (got " << r.smoothed_gradient_rounds << "); ";
}

/// sync/*, frames/*, window/* and deskew/*.
template <typename Visit>
void readSyncWindowAndDeskew(Visit& get, NodeParams* p) {
  get("sync/approximate", &p->approximate_sync);
  get("sync/queue_size", &p->sync_queue);
  get("sync/max_skew", &p->online.max_sync_skew);
  get("sync/max_stereo_skew", &p->max_stereo_skew);
  get("image_transport", &p->image_transport);
  get("frames/lidar", &p->lidar_frame);
  get("frames/left", &p->left_frame);
  get("frames/right", &p->right_frame);
  get("window/keyframe_min_dt", &p->online.keyframe_min_dt);
  get("window/size", &p->online.window_size);
  get("window/min_keyframes", &p->online.min_keyframes);
  get("window/min_keyframes_co", &p->online.min_keyframes_co);
  get("window/max_variance_growth", &p->online.max_variance_growth);
  get("window/max_variance_growth_first_co", &p->online.max_variance_growth_first_co);
  get("window/changed_chi2", &p->online.changed_chi2);
  get("window/warm_start_fine_only", &p->online.warm_start_fine_only);
  get("window/keyframe_selection", &p->online.keyframe_selection);
  get("window/max_time_jump_back", &p->online.max_time_jump_back);
  get("deskew/enabled", &p->online.deskew);
  get("deskew/max_dt", &p->online.deskew_max_dt);
  get("deskew/rate_hz", &p->online.sweep.rate_hz);
  get("deskew/clockwise", &p->online.sweep.clockwise);
  get("deskew/by_azimuth", &p->online.sweep.by_azimuth);
  double reference_azimuth_deg = p->online.sweep.reference_azimuth_rad * 180.0 / M_PI;
  get("deskew/reference_azimuth_deg", &reference_azimuth_deg);
  p->online.sweep.reference_azimuth_rad = reference_azimuth_deg * M_PI / 180.0;
}

/// co_calibration/*, stereo/* and images/*.
/// monitor/*: the calibration monitor (MonitorSettings); quality/enabled.
template <typename Visit>
void readMonitor(Visit& get, NodeParams* p) {
  get("quality/enabled", &p->quality_enabled);
  get("monitor/action", &p->online.monitor.action);
  get("monitor/cusum_k", &p->online.monitor.cusum_k);
  get("monitor/cusum_h", &p->online.monitor.cusum_h);
  get("monitor/change_span_s", &p->online.monitor.change_span_s);
  get("monitor/fresh_fraction", &p->online.monitor.fresh_fraction);
  get("monitor/pair_check_keyframes", &p->online.monitor.pair_check_keyframes);
  get("monitor/average_windows", &p->online.monitor.average_windows);
  get("monitor/pair_check_lidar_change_deg", &p->online.monitor.pair_check_lidar_change_deg);
  get("monitor/pair_check_lidar_change_m", &p->online.monitor.pair_check_lidar_change_m);
}

template <typename Visit>
void readCoCalibrationAndStereo(Visit& get, NodeParams* p) {
  get("co_calibration/estimate_stereo", &p->online.estimate_stereo);
  get("co_calibration/joint", &p->online.joint);
  get("co_calibration/max_rounds", &p->online.co.max_rounds);
  get("co_calibration/warm_co_rounds", &p->online.warm_co_rounds);
  get("co_calibration/lidar_estimates_stereo_yaw", &p->online.co.lidar_estimates_stereo_yaw);
  get("co_calibration/lidar_first", &p->online.lidar_first);
  get("co_calibration/free_depth_rounds", &p->online.co.free_depth_rounds);
  get("co_calibration/rematch_deg", &p->online.co.rematch_deg);
  get("co_calibration/yaw_handover_deg", &p->online.co.yaw_handover_deg);
  get("co_calibration/stereo_from_features", &p->online.co.stereo_from_features);
  get("co_calibration/fine_stereo_normal_px", &p->online.co.fine_stereo_normal_px);
  get("co_calibration/halves_from_initial_guess", &p->online.co.halves_always_from_initial_guess);
  get("stereo/num_disparities", &p->online.keyframe.stereo.num_disparities);
  get("stereo/block_size", &p->online.keyframe.stereo.block_size);
  get("stereo/sgbm_paths", &p->online.keyframe.stereo.sgbm_paths);
  get("stereo/sgbm_both_ways", &p->online.keyframe.stereo.sgbm_both_ways);
  get("stereo/rectified_vertical_blur_px", &p->online.keyframe.stereo.rectified_vertical_blur_px);
  get("stereo/max_depth", &p->online.keyframe.stereo.max_depth);
  get("stereo/max_row_offset_px", &p->online.max_row_offset_px);
  get("stereo/align_rows", &p->online.align_rows);
  get("stereo/align_rows_min_px", &p->online.align_rows_min_px);
  get("stereo/min_points", &p->online.min_stereo_points);
  get("images/min_contrast", &p->online.image_quality.min_contrast);
  get("images/max_clipped_difference", &p->online.image_quality.max_clipped_difference);
  get("images/min_sharpness_ratio", &p->online.image_quality.min_sharpness_ratio);
  get("stereo/disparity_sigma", &p->online.keyframe.stereo.disparity_sigma);
  get("stereo/equalize_exposure_ratio", &p->online.keyframe.stereo.equalize_exposure_ratio);
  get("stereo/refine_iterations", &p->online.keyframe.stereo.refinement.iterations);
  get("stereo/refine_window_radius", &p->online.keyframe.stereo.refinement.window_radius);
  get("stereo/refine_smoothed_rounds",
      &p->online.keyframe.stereo.refinement.smoothed_gradient_rounds);
}

/// lidar_stereo/*, photometric/*, initial/*, save_path and the co-calibration's stereo clouds.
template <typename Visit>
void readSolversAndStart(Visit& get, NodeParams* p) {
  get("lidar_stereo/normal_weight", &p->online.co.lidar.normal_weight);
  get("lidar_stereo/lidar_range_sigma", &p->online.co.lidar.lidar_range_sigma);
  get("lidar_stereo/max_depth", &p->online.co.lidar.max_depth);
  get("lidar_stereo/check_window_halves", &p->online.co.lidar.check_window_halves);
  get("lidar_stereo/halves_chi2_limit", &p->online.co.lidar.halves_chi2_limit);
  get("lidar_stereo/halves_start", &p->halves_start);
  get("lidar_stereo/measure_disparity_offset", &p->online.co.lidar.measure_disparity_offset);
  get("lidar_stereo/estimate_stereo_scale", &p->online.co.lidar.estimate_stereo_scale);
  get("lidar_stereo/search_deg", &p->online.co.lidar.search_step_deg);
  get("lidar_stereo/search_min_keyframes", &p->online.search_min_keyframes);
  get("lidar_stereo/consistent_sample", &p->online.keyframe.mesh.consistent_sample);
  get("lidar_stereo/ring_clusters", &p->online.co.lidar.ring_cluster_rings);
  get("lidar_stereo/ring_range_sigma", &p->online.co.lidar.ring_range_sigma_m);
  get("lidar_stereo/fine_stereo_normal_px", &p->online.co.lidar.fine_stereo_normal_px);
  get("photometric/pyramid_levels", &p->online.co.stereo.pyramid_levels);
  get("photometric/huber", &p->online.co.stereo.huber);
  get("initial/T_cam_lidar", &p->initial_T_cam_lidar);
  get("initial/T_right_left", &p->initial_T_right_left);
  get("initial/tf_camera_frame", &p->initial_tf_camera_frame);
  get("initial/perturb_rot_deg", &p->initial_perturb_rot_deg);
  get("initial/perturb_trans_m", &p->initial_perturb_trans_m);
  get("initial/perturb_seed", &p->initial_perturb_seed);
  get("save_path", &p->save_path);
  p->online.co.stereo_cloud = coStereoCloudSettings(p->online.keyframe.stereo);
  get("co_calibration/refine_iterations", &p->online.co.stereo_cloud.refinement.iterations);
  get("co_calibration/refine_smoothed_rounds",
      &p->online.co.stereo_cloud.refinement.smoothed_gradient_rounds);
}

/// The names under `pnh` that `read` does not hold (typos), sorted.
std::vector<std::string> unknownNames(const ros::NodeHandle& pnh, const std::set<std::string>& read,
                                      const std::string& image_transport) {
  std::vector<std::string> unknown;
  std::vector<std::string> all;
  ros::param::getParamNames(all);
  const std::string prefix = pnh.getNamespace() + "/";
  for (const std::string& name : all) {
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string key = name.substr(prefix.size());
    // image_transport's subscriber plugins keep their own parameters under
    // ~<transport>/ (compressed/mode, theora/...): not ours, and not typos.
    const std::string first = key.substr(0, key.find('/'));
    if (key.find('/') != std::string::npos && (first == image_transport || first == "compressed" ||
                                               first == "compressedDepth" || first == "theora"))
      continue;
    if (!read.count(key)) unknown.push_back(key);
  }
  std::sort(unknown.begin(), unknown.end());
  return unknown;
}

}  // namespace

bool loadNodeParams(const ros::NodeHandle& pnh, NodeParams* p, std::string* error,
                    std::vector<std::string>* unknown) {
  Reader get{pnh, {}, {}};
  readSyncWindowAndDeskew(get, p);
  readMonitor(get, p);
  readCoCalibrationAndStereo(get, p);
  readSolversAndStart(get, p);
  if (unknown) *unknown = unknownNames(pnh, get.names, p->image_transport);
  halvesStartFromName(p->halves_start, &p->online.co.lidar.halves_start);
  const bool valid = validateNodeParams(*p, error);
  *error = get.wrong_type.str() + *error;
  return valid && get.wrong_type.str().empty();
}

namespace {

/// NaN fails these too: it compares false with everything, so "x <= 0" would let it through.
bool positive(double x) { return x > 0 && std::isfinite(x); }
bool nonNegative(double x) { return x >= 0 && std::isfinite(x); }

/// window/*, stereo/min_points and images/*.
void checkWindowAndImages(const OnlineSettings& o, std::ostringstream& e) {
  if (!positive(o.keyframe_min_dt))
    e << "window/keyframe_min_dt must be > 0 (got " << o.keyframe_min_dt << "); ";
  if (o.window_size < 1) e << "window/size must be >= 1 (got " << o.window_size << "); ";
  if (!nonNegative(o.max_time_jump_back))
    e << "window/max_time_jump_back must be >= 0 s (got " << o.max_time_jump_back << "); ";
  if (o.min_keyframes < 1 || o.min_keyframes > o.window_size)
    e << "window/min_keyframes must be in [1, window/size] (got " << o.min_keyframes
      << ", window/size " << o.window_size << "); ";
  if (o.estimate_stereo && (o.min_keyframes_co < 1 || o.min_keyframes_co > o.window_size))
    e << "window/min_keyframes_co must be in [1, window/size] with co_calibration/estimate_stereo "
         "(got "
      << o.min_keyframes_co << ", window/size " << o.window_size << "); ";
  if (!(o.max_variance_growth >= 1 && std::isfinite(o.max_variance_growth)))
    e << "window/max_variance_growth must be >= 1 (got " << o.max_variance_growth << "); ";
  if (!(o.max_variance_growth_first_co >= 1))
    e << "window/max_variance_growth_first_co must be >= 1; ";
  if (!(o.changed_chi2 > 0)) e << "window/changed_chi2 must be > 0; ";
  if (o.min_stereo_points < 0) e << "stereo/min_points must be >= 0; ";
  if (!nonNegative(o.align_rows_min_px))
    e << "stereo/align_rows_min_px must be >= 0 px (got " << o.align_rows_min_px << "); ";
  if (!(o.image_quality.min_contrast >= 0))
    e << "images/min_contrast must be >= 0 (0: no check; got " << o.image_quality.min_contrast
      << "); ";
  if (!(o.image_quality.max_clipped_difference > 0 && o.image_quality.max_clipped_difference <= 1))
    e << "images/max_clipped_difference must be in (0, 1] (1: no check; got "
      << o.image_quality.max_clipped_difference << "); ";
  if (!(o.image_quality.min_sharpness_ratio >= 0 && o.image_quality.min_sharpness_ratio < 1))
    e << "images/min_sharpness_ratio must be in [0, 1) (0: no check; got "
      << o.image_quality.min_sharpness_ratio << "); ";
  if (o.keyframe_selection != "information" && o.keyframe_selection != "fifo")
    e << "window/keyframe_selection must be information or fifo (got '" << o.keyframe_selection
      << "'); ";
}

/// sync/*, deskew/* and image_transport.
void checkSyncAndDeskew(const NodeParams& p, std::ostringstream& e) {
  const auto& o = p.online;
  if (!positive(o.max_sync_skew)) e << "sync/max_skew must be > 0; ";
  if (!positive(p.max_stereo_skew)) e << "sync/max_stereo_skew must be > 0; ";
  if (!positive(o.deskew_max_dt))
    e << "deskew/max_dt must be > 0 (got " << o.deskew_max_dt << "); ";
  if (!std::isfinite(o.sweep.reference_azimuth_rad))
    e << "deskew/reference_azimuth_deg must be a number; ";
  if (!positive(o.sweep.rate_hz))
    e << "deskew/rate_hz must be > 0 (got " << o.sweep.rate_hz << "); ";
  if (p.sync_queue < 1) e << "sync/queue_size must be >= 1; ";
  if (p.image_transport.empty() || p.image_transport.find('/') != std::string::npos)
    e << "image_transport must be a transport's name (raw, compressed, ...; got \""
      << p.image_transport << "\"); ";
}

/// The keyframes' stereo matching and the disparity refinements.
void checkStereo(const OnlineSettings& o, std::ostringstream& e) {
  if (o.keyframe.stereo.num_disparities < 16 || o.keyframe.stereo.num_disparities % 16)
    e << "stereo/num_disparities must be a positive multiple of 16 (got "
      << o.keyframe.stereo.num_disparities << "); ";
  if (o.keyframe.stereo.block_size < 1 || o.keyframe.stereo.block_size % 2 == 0)
    e << "stereo/block_size must be a positive odd number (got " << o.keyframe.stereo.block_size
      << "); ";
  if (!validSgbmPaths(o.keyframe.stereo.sgbm_paths))
    e << "stereo/sgbm_paths must be 3, 5 or 8 (got " << o.keyframe.stereo.sgbm_paths << "); ";
  if (!positive(o.keyframe.stereo.disparity_sigma)) e << "stereo/disparity_sigma must be > 0; ";
  if (!(o.keyframe.stereo.rectified_vertical_blur_px >= 0) ||
      !std::isfinite(o.keyframe.stereo.rectified_vertical_blur_px))
    e << "stereo/rectified_vertical_blur_px must be >= 0 px (got "
      << o.keyframe.stereo.rectified_vertical_blur_px << "); ";
  if (!std::isfinite(o.keyframe.stereo.equalize_exposure_ratio))
    e << "stereo/equalize_exposure_ratio must be a number (<= 1: off); ";
  checkRefinementRounds(o.keyframe.stereo.refinement, "stereo/", e);
  if (o.keyframe.stereo.refinement.window_radius < 1 ||
      o.keyframe.stereo.refinement.window_radius > 15)
    e << "stereo/refine_window_radius must be between 1 and 15 px (got "
      << o.keyframe.stereo.refinement.window_radius << "); ";
  checkRefinementRounds(o.co.stereo_cloud.refinement, "co_calibration/", e);
}

/// co_calibration/*, lidar_stereo/*, photometric/* and the depth limits of both clouds.
void checkSolvers(const OnlineSettings& o, std::ostringstream& e) {
  if (o.co.max_rounds < 1) e << "co_calibration/max_rounds must be >= 1; ";
  if (o.joint && !o.estimate_stereo)
    e << "co_calibration/joint (the one-problem co-calibration) needs "
         "co_calibration/estimate_stereo: true; ";
  if (o.warm_co_rounds < 1) e << "co_calibration/warm_co_rounds must be >= 1; ";
  if (o.co.free_depth_rounds < 0) e << "co_calibration/free_depth_rounds must be >= 0; ";
  if (o.co.fine_stereo_normal_px < 0)
    e << "co_calibration/fine_stereo_normal_px must be >= 0 (got " << o.co.fine_stereo_normal_px
      << "); ";
  if (o.co.rematch_deg == 0 || !std::isfinite(o.co.rematch_deg))
    e << "co_calibration/rematch_deg must be > 0 (< 0: always match); ";
  if (o.co.yaw_handover_deg == 0 || !std::isfinite(o.co.yaw_handover_deg))
    e << "co_calibration/yaw_handover_deg must be > 0 (< 0: never hand over); ";
  if (!(o.co.lidar.halves_chi2_limit > 0))
    e << "lidar_stereo/halves_chi2_limit must be > 0 (got " << o.co.lidar.halves_chi2_limit
      << "); ";
  if (!(o.co.lidar.search_step_deg >= 0 &&
        o.co.lidar.search_step_deg <= LidarStereoSettings::kMaxSearchStepDeg))
    e << "lidar_stereo/search_deg must be between 0 (off) and "
      << LidarStereoSettings::kMaxSearchStepDeg << " deg (got " << o.co.lidar.search_step_deg
      << "); ";
  if (o.co.lidar.ring_cluster_rings < 0)
    e << "lidar_stereo/ring_clusters must be >= 0 (got " << o.co.lidar.ring_cluster_rings << "); ";
  if (o.co.lidar.fine_stereo_normal_px < 0)
    e << "lidar_stereo/fine_stereo_normal_px must be >= 0 (got " << o.co.lidar.fine_stereo_normal_px
      << "); ";
  if (!(o.co.lidar.ring_range_sigma_m >= 0))
    e << "lidar_stereo/ring_range_sigma must be >= 0 m (got " << o.co.lidar.ring_range_sigma_m
      << "); ";
  if (o.search_min_keyframes < 1)
    e << "lidar_stereo/search_min_keyframes must be >= 1 (got " << o.search_min_keyframes << "); ";
  if (o.co.stereo.pyramid_levels < 1 || o.co.stereo.pyramid_levels > 5)
    e << "photometric/pyramid_levels must be in [1, 5]; ";
  // 0 makes every keyframe fail as "a dark, blurred ... right image" (stereo) or every solve as
  // "too few associations" (LiDAR-stereo); below the clouds' fixed near limit
  // (StereoSettings::min_depth) every cloud is empty.
  if (!(o.keyframe.stereo.max_depth > o.keyframe.stereo.min_depth))
    e << "stereo/max_depth must be beyond the stereo clouds' near limit of "
      << o.keyframe.stereo.min_depth << " m (got " << o.keyframe.stereo.max_depth << "); ";
  if (!(o.co.lidar.max_depth > 0))
    e << "lidar_stereo/max_depth must be > 0 m (got " << o.co.lidar.max_depth << "); ";
  // > 0, as the LiDAR-stereo solver requires (0 would start a node whose every solve is refused).
  if (!positive(o.co.lidar.normal_weight))
    e << "lidar_stereo/normal_weight must be > 0 (got " << o.co.lidar.normal_weight << "); ";
  if (!positive(o.co.lidar.lidar_range_sigma))
    e << "lidar_stereo/lidar_range_sigma must be > 0 m (got " << o.co.lidar.lidar_range_sigma
      << "); ";
  if (!positive(o.co.stereo.huber))
    e << "photometric/huber must be > 0 (got " << o.co.stereo.huber << "); ";
}

/// initial/* and frames/*.
void checkStartAndFrames(const NodeParams& p, std::ostringstream& e) {
  for (const auto& [name, v] : {std::pair{"initial/T_cam_lidar", &p.initial_T_cam_lidar},
                                std::pair{"initial/T_right_left", &p.initial_T_right_left}}) {
    if (v->empty()) continue;
    if (v->size() != 7) {
      e << name << " must be [x, y, z, qx, qy, qz, qw] (7 values, got " << v->size() << "); ";
      continue;
    }
    bool finite = true;
    for (double x : *v) finite = finite && std::isfinite(x);
    const double qnorm =
        std::sqrt((*v)[3] * (*v)[3] + (*v)[4] * (*v)[4] + (*v)[5] * (*v)[5] + (*v)[6] * (*v)[6]);
    if (!finite)
      e << name << " must hold 7 finite numbers; ";
    else if (qnorm < 1e-6)  // Eigen would "normalise" a zero quaternion to itself
      e << name << "'s quaternion [qx, qy, qz, qw] must not be zero; ";
  }
  if (p.initial_T_right_left.size() == 7 &&
      std::hypot(p.initial_T_right_left[0], p.initial_T_right_left[1], p.initial_T_right_left[2]) <
          1e-3)
    e << "initial/T_right_left must have a baseline (its translation is under 1 mm); ";
  if (!nonNegative(p.initial_perturb_rot_deg) || !nonNegative(p.initial_perturb_trans_m))
    e << "initial/perturb_rot_deg and initial/perturb_trans_m must be sizes, >= 0 (got "
      << p.initial_perturb_rot_deg << ", " << p.initial_perturb_trans_m << "); ";
  if (p.left_frame.empty() || p.right_frame.empty())
    e << "frames/left and frames/right must be set; ";
}

}  // namespace

/// monitor/*.
void checkMonitor(const MonitorSettings& m, std::ostringstream& e) {
  if (m.action != "recalibrate" && m.action != "flag" && m.action != "off")
    e << "monitor/action must be recalibrate, flag or off (got '" << m.action << "'); ";
  if (!positive(m.cusum_k)) e << "monitor/cusum_k must be > 0 (got " << m.cusum_k << "); ";
  if (!positive(m.cusum_h)) e << "monitor/cusum_h must be > 0 (got " << m.cusum_h << "); ";
  if (!nonNegative(m.change_span_s))
    e << "monitor/change_span_s must be >= 0 s (got " << m.change_span_s << "); ";
  if (!(m.fresh_fraction > 0 && m.fresh_fraction <= 1))
    e << "monitor/fresh_fraction must be in (0, 1] (got " << m.fresh_fraction << "); ";
  if (m.average_windows < 1)
    e << "monitor/average_windows must be >= 1 (got " << m.average_windows << "); ";
  if (m.pair_check_keyframes < 0)
    e << "monitor/pair_check_keyframes must be >= 0 (got " << m.pair_check_keyframes << "); ";
  if (!nonNegative(m.pair_check_lidar_change_deg) || !nonNegative(m.pair_check_lidar_change_m))
    e << "monitor/pair_check_lidar_change_deg and _m must be >= 0; ";
}

bool validateNodeParams(const NodeParams& p, std::string* error) {
  std::ostringstream e;
  checkWindowAndImages(p.online, e);
  checkMonitor(p.online.monitor, e);
  checkSyncAndDeskew(p, e);
  checkStereo(p.online, e);
  checkSolvers(p.online, e);
  checkStartAndFrames(p, e);
  HalvesStart start;
  if (!halvesStartFromName(p.halves_start, &start))
    e << "lidar_stereo/halves_start must be recheck, estimate, initial or always (got '"
      << p.halves_start << "'); ";
  *error = e.str();
  return error->empty();
}

std::map<std::string, std::string> nodeParamValues(NodeParams p) {
  Collector get;
  readSyncWindowAndDeskew(get, &p);
  readMonitor(get, &p);
  readCoCalibrationAndStereo(get, &p);
  readSolversAndStart(get, &p);
  return get.values;
}

}  // namespace tescalib
