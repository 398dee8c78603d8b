// The online calibrator's publish policy: whether a solve's estimate replaces the published one,
// and why not. Never something less trustworthy: not converged, a covariance that is not finite,
// fewer keyframes than the published estimate's, or a variance on some axis that grew beyond
// OnlineSettings::max_variance_growth (max_variance_growth_first_co for the first co-calibrated
// estimate after LiDAR-first ones). An estimate held back that disagrees with the published one
// beyond the two covariances (OnlineSettings::changed_chi2) says that the extrinsic may have
// changed since.
#pragma once

#include <optional>
#include <string>

#include "tescalib/core/online/online_estimate.h"
#include "tescalib/core/online/online_settings.h"

namespace tescalib {

/// e^T (P + P_published)^-1 e of `candidate`'s T_cam_lidar against `published`'s (6 DoF, the
/// two covariances taken as independent); NaN when nothing is published, `candidate` did not
/// converge, or the summed covariance is not positive definite.
double chi2ToPublished(const OnlineEstimate& candidate,
                       const std::optional<OnlineEstimate>& published);

/// Why `candidate` is held back instead of replacing `published` (nothing published yet
/// included); empty when it is published. `solve_message` is the solver's (why it did not
/// converge). A held-back converged estimate's reason ends with its chi2_to_published and, beyond
/// changed_chi2, the note that the extrinsic may have changed. `recalibrating`: the calibration
/// monitor declared the published extrinsic changed and the window restarted; the candidate is
/// then not held to the published covariance (max_variance_growth), only to the window's
/// keyframe count.
std::string publicationRefusal(const OnlineEstimate& candidate,
                               const std::optional<OnlineEstimate>& published,
                               const OnlineSettings& settings, const std::string& solve_message,
                               bool recalibrating = false);

}  // namespace tescalib
