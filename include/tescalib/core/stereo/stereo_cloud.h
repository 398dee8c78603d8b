// Stereo cloud of one keyframe (paper, "Data Preprocessing"): rectification with the current
// left->right estimate, OpenCV SGBM disparity, 3D points in the left camera frame with normals and
// their disparity (for the noise model), and the disparity image itself for projective look-ups.
#pragma once

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "tescalib/core/common/types.h"
#include "tescalib/core/stereo/disparity_refinement.h"

namespace tescalib {

struct StereoSettings {
  int num_disparities = 128;  ///< SGBM search range (multiple of 16)
  int block_size = 5;         ///< SGBM block size (odd)
  /// SGBM's aggregation paths: 3 (MODE_SGBM_3WAY), 5 (MODE_SGBM) or 8 (MODE_HH). 3 and 5 run
  /// in one pass over the image from its top row, so their smoothness reaches each pixel from
  /// the rows above alone: a surface whose disparity changes with the row (the road) matches
  /// as if shifted upwards, about 0.4 row under the generator's image noise (disparity error
  /// -0.42 px x dd/dv on random rig 307; tescalib_error_budget), unless `sgbm_both_ways`. 8 adds
  /// the paths from below, with no such shift (+0.007 px x dd/dv), at about 3x the time and
  /// about 4 bytes x W x H x num_disparities of memory while matching (200 MB more at 1241x376).
  int sgbm_paths = 3;
  /// Match the pair twice, upright and upside down, and keep per pixel the mean of the two
  /// disparities where both passes found one and they lie within `both_ways_max_diff_px` of each
  /// other (none elsewhere). The upside-down pass aggregates from the bottom row, so its matches
  /// shift downwards by as much as the upright pass's shift upwards, and their mean does not
  /// shift: with 3 paths the road's disparity error near the camera goes from -0.14 to +0.002 px
  /// on random rig 307 and from -0.03 to -0.005 px on the default rig (tescalib_error_budget,
  /// 6 keyframes), at twice the matching time of one pass and no more memory. Meant for 3 and 5
  /// paths (8 do not shift: with 8 it only doubles the time). Off: one upright pass, half the
  /// matching time, with the road's shift (doc/limitations.md).
  bool sgbm_both_ways = true;
  /// px; the two passes of `sgbm_both_ways` disagreeing by more: two different matches (a depth
  /// edge, a repeated texture), dropped. Their shifts differ by a fraction of a pixel.
  double both_ways_max_diff_px = 2.0;
  int uniqueness_ratio = 10;      ///< SGBM uniqueness margin (%)
  int speckle_window = 100;       ///< SGBM speckle filter window (px)
  int speckle_range = 2;          ///< SGBM speckle filter range (disparity units)
  int disp12_max_diff = 1;        ///< left-right consistency check (px)
  int sample_step = 4;            ///< take one stereo point every N pixels in u and v
  double min_depth = 2.0;         ///< m
  double max_depth = 40.0;        ///< m; stereo depth noise grows with Z^2, far points carry little
  int normal_scale = 3;           ///< px; half-width of the finite differences for normals
  double max_second_diff = 1.5;   ///< px; disparity is affine on a plane: larger curvature = edge
  int edge_dilation = 2;          ///< px removed around an edge (SGBM fattens foreground ~block/2)
  double disparity_sigma = 0.35;  ///< px; SGBM sub-pixel noise used by the noise model
  /// When the pair's mean grey value or contrast (standard deviation) differ by more than this
  /// factor, the image with the lower contrast is mapped onto the other's grey-value histogram
  /// before SGBM, which compares grey values (matchExposure). Decided on the images as delivered,
  /// so every re-rectification of a keyframe decides alike. Without it, with a right image
  /// exposed 1.5x / 2x the left, a generated window keeps 2691 / 593 of 11460 stereo points per
  /// keyframe and its LiDAR-stereo solve ends 29 cm off at 2x; KITTI's 00 frame 0 keeps 655 of 9509
  /// at 1.6x. Generated pairs (contrast ratio 0.90) and KITTI's (0.98-1.05) are within it, so not
  /// changed. <= 1: off.
  double equalize_exposure_ratio = 1.15;
  /// px; 1-sigma of a Gaussian low-pass along the image's columns (vertical only) applied to
  /// both images of a pair that is re-rectified (its right camera off the left camera's x axis,
  /// or turned), before matching; 0: off. A pair whose right camera sits a few mm above or
  /// below the left camera's x axis is re-rectified about the optical axis, and SGBM's match of
  /// the re-rectified images errs one way left of the image's centre and the other way right of
  /// it: a tilt of the disparity error across the image (0.03-0.09 px between the image's outer
  /// thirds for 3 mm), which turns the estimate about the camera's y and z axes. The remap's
  /// interpolation does not cause it (Lanczos leaves it as it is), nor does the pair's geometry
  /// (a pair off the axis along the optical axis alone shows none); a vertical low-pass of both
  /// images takes most of it out (doc/limitations.md). Along the rows the images keep their
  /// detail, which the disparity's precision needs. A pair rectified as delivered is not touched.
  double rectified_vertical_blur_px = 0.8;
  DisparityRefinementSettings refinement;  ///< slanted-window sub-pixel refinement after SGBM
  /// Keyframes whose clouds are computed at the same time when a whole window is (re)computed
  /// (0: one per core); one cloud uses OpenCV's own threads. The clouds do not depend on it.
  int threads = 0;
};

/// A stereo point in the left camera frame.
struct StereoPoint {
  Eigen::Vector3f p;    ///< position, m
  Eigen::Vector3f n;    ///< unit normal, oriented towards the camera
  float disparity = 0;  ///< px
};

struct StereoCloud {
  std::vector<StereoPoint> points;
  /// Disparity in the rectified left image (CV_32F, NaN where invalid or at an edge).
  cv::Mat disparity;
  /// Rectified intrinsics and baseline; `R_rect_left` rotates left-camera points into the
  /// rectified frame (identity when the input pair was already rectified).
  double fx = 0, fy = 0, cx = 0, cy = 0, baseline = 0;
  Eigen::Matrix3d R_rect_left = Eigen::Matrix3d::Identity();
  /// The same for the right camera (its points into its rectified frame).
  Eigen::Matrix3d R_rect_right = Eigen::Matrix3d::Identity();
  /// One image was mapped onto the other's grey values before matching
  /// (StereoSettings::equalize_exposure_ratio).
  bool exposure_equalized = false;
  /// px; the column low-pass both images were filtered with before matching
  /// (StereoSettings::rectified_vertical_blur_px on a re-rectified pair; 0: none).
  double vertical_low_pass_px = 0;
  double seconds_sgbm = 0;   ///< time spent in SGBM
  double seconds_total = 0;  ///< time for the whole cloud

  /// Bilinear disparity at a rectified pixel; false where any of the 4 neighbours is invalid.
  bool disparityAt(double u, double v, double* d) const;
  /// The stereo point (left camera frame) seen at rectified pixel (u, v) with disparity d.
  Eigen::Vector3d pointAt(double u, double v, double d) const;
};

/// Whether `paths` is a StereoSettings::sgbm_paths SGBM has: 3, 5 or 8.
inline bool validSgbmPaths(int paths) { return paths == 3 || paths == 5 || paths == 8; }

/// Maps the image of the pair (8-bit grey) with the lower contrast onto the other's grey-value
/// histogram when their means or contrasts differ by more than `ratio_limit` (> 1; otherwise, and
/// within it, the images are left alone). Returns whether it mapped one.
bool matchExposure(cv::Mat* left_grey, cv::Mat* right_grey, double ratio_limit);

/// True when `T_right_left` is a pure translation along x (the pair needs no re-rectification).
bool isRectified(const Eigen::Isometry3d& T_right_left, double tol = 1e-9);

/// The rectified baseline (m) a left->right estimate gives the pair, as the stereo clouds
/// rectify it (OpenCV's stereoRectify at the left image's size). Not above 0: the pair cannot be
/// rectified side by side (the right camera not to the right of the left one, or a baseline
/// more vertical than horizontal), and computeStereoCloud would refuse it (DataError).
double rectifiedBaseline(const StereoRig& rig, const Eigen::Isometry3d& T_right_left);

/// Computes the stereo cloud of a pair with the left->right estimate `T_right_left` (the rig's
/// intrinsics are used; the pair is re-rectified when the estimate is not a pure x translation
/// or the two cameras' focal lengths differ).
StereoCloud computeStereoCloud(const cv::Mat& left_bgr, const cv::Mat& right_bgr,
                               const StereoRig& rig, const Eigen::Isometry3d& T_right_left,
                               const StereoSettings& settings = {});

/// The cloud of the same matches with another left->right estimate, without matching again:
/// every pixel pair SGBM matched in `matched`'s rectification is triangulated with
/// `T_right_left` (its disparity in the new rectification, then the points), where the new
/// pixel's bilinear neighbours in the old disparity are all matched (every pixel when the
/// rectification is unchanged). Exact for the matches; the matches themselves are as good as
/// `matched`'s rectification was (a vertical misalignment of the images SGBM saw stays), so it
/// serves small changes of the estimate.
StereoCloud retriangulateStereoCloud(const StereoCloud& matched, const StereoRig& rig,
                                     const Eigen::Isometry3d& T_right_left,
                                     const StereoSettings& settings = {});

}  // namespace tescalib
