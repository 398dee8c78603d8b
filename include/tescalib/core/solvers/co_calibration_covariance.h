// The covariances of a co-calibration (paper, "Uncertainty Analysis", for the alternation of
// "Co-calibration"): each solve's covariance is conditional on the other extrinsic being exact;
// here each extrinsic's uncertainty is propagated into the other's.
#pragma once

#include <vector>

#include "tescalib/core/solvers/keyframe.h"
#include "tescalib/core/solvers/lidar_stereo_solver.h"
#include "tescalib/core/solvers/photometric_solver.h"

namespace tescalib {

struct CoCalibrationSettings;  // co_calibration.h
struct CoCalibrationResult;    // co_calibration.h

/// CoCalibrationSettings::model_sigma_stereo_scale added to `lidar`'s stereo scale variance and,
/// through its stereo_scale_sensitivity, to its covariance (for the window's f B; nothing without
/// a known covariance).
void addScaleFloor(const LidarStereoSettings& lidar_settings, const CoCalibrationSettings& s,
                   LidarStereoResult* lidar);

/// d T_cam_lidar / d T_right_left at the converged LiDAR-stereo result `lidar` of `window`'s
/// current clouds: for the right camera's rotation about x and z and the baseline's y and z
/// components, the clouds are re-triangulated from their matches with the pair perturbed by
/// +-`s.sensitivity_step_*` and the fine stage is solved again from `lidar` (`settings`, no
/// coarse stage, its own tolerances); the columns of the clouds' yaw and of the length are zero
/// (the solve estimates those). The clouds are restored afterwards. `seconds` (optional)
/// receives the time.
Matrix6d lidarSensitivityToStereo(const std::vector<Keyframe*>& window, const StereoRig& rig,
                                  const LidarStereoResult& lidar, LidarStereoSettings settings,
                                  const CoCalibrationSettings& s, double* seconds = nullptr);

/// The left-right covariance of a co-calibration, from the last photometric solve `stereo`
/// (conditional on the LiDAR extrinsic) and the final LiDAR-stereo solve `lidar`: adds the
/// baseline length's variance from the stereo scale (with `photometric_fixed_length`), the LiDAR
/// covariance through `stereo->lidar_sensitivity` (without its length component), evaluates the
/// trust flags again with both (a stereo result that loses an axis is no longer converged) and
/// adds the model error. Returns whether every axis is still trusted.
bool coStereoCovariance(const LidarStereoResult& lidar, const CoCalibrationSettings& settings,
                        PhotometricResult* stereo);
/// The same with `lidar_covariance` (coCalibrate: the LiDAR's covariance given the pair, since
/// the propagated one holds the pair's own uncertainty) instead of `lidar.covariance`, and with
/// `lidar_sensitivity_to_stereo` (optional, d T_cam_lidar / d T_right_left) the alternation's
/// fixed-point gain (CoCalibrationSettings::stereo_fixed_point_gain).
bool coStereoCovariance(const LidarStereoResult& lidar, const CoCalibrationSettings& settings,
                        PhotometricResult* stereo, const Matrix6d& lidar_covariance,
                        const Matrix6d* lidar_sensitivity_to_stereo = nullptr);

/// The final covariances of coCalibrate's result `res` (its last solves, `lidar_settings` those
/// of the last LiDAR-stereo solve, on `window`'s current clouds): the LiDAR covariance given the
/// pair, the pair's uncertainty propagated into the LiDAR one (propagate_stereo_into_lidar, with
/// the alternation's gain; sets `lidar_stereo_sensitivity` and `coupling`), both model errors,
/// and the pair's covariance with the LiDAR's (coStereoCovariance). Adds its time to
/// `res->seconds_lidar`.
void coCalibrationCovariances(const std::vector<Keyframe*>& window, const StereoRig& rig,
                              const LidarStereoSettings& lidar_settings,
                              const CoCalibrationSettings& s, CoCalibrationResult* res);

}  // namespace tescalib
