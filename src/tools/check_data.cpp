// tescalib_check_data: opens KITTI sequences (odometry or raw layout) and reports what the reader
// sees, whether the dataset's own calibration predicts the stereo disparity and how well the
// rectified pair's rows agree: a quick check of a user's data before calibrating.
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <set>
#include <string>
#include <vector>

#include "cli.h"
#include "tescalib/core/common/error.h"
#include "tescalib/core/common/geometry.h"
#include "tescalib/core/common/pose_format.h"
#include "tescalib/core/eval/disparity_signatures.h"
#include "tescalib/core/eval/lidar_stereo_agreement.h"
#include "tescalib/core/io/kitti_reader.h"
#include "tescalib/core/stereo/image_quality.h"
#include "tescalib/core/stereo/row_alignment.h"
#include "tescalib/core/stereo/stereo_cloud.h"

namespace {

const char* const kUsage = "usage: rosrun tescalib tescalib_check_data DIR [DIR...] [--frames N]";
const char* const kDescription =
    "DIR: a KITTI sequence (odometry or raw layout, or tescalib_simulate output). Prints the "
    "frames, keyframes and rings the reader sees, how well the data's own calibration predicts "
    "the stereo disparity (SGBM minus the LiDAR-predicted disparity by depth, by third of the "
    "image and by ring, and its fit as an offset plus a scale of the disparity) and whether the "
    "right image's rows are where that calibration puts them, and the pair's contrast, clipped "
    "pixels and sharpness as the online node's image check sees them.";

/// What the reader sees: layout, frames, keyframes, image size, the calibration and the first
/// frame's scan, and whether the calibration predicts the LiDAR points' disparity.
void printReader(const std::string& dir, const tescalib::KittiSequence& seq,
                 const tescalib::Frame& f) {
  const auto& rig = seq.rig();
  const auto kf = seq.keyframes(0.5);
  std::set<int> rings;
  for (const auto& p : f.scan) rings.insert(p.ring);
  const auto agree =
      tescalib::lidarDisparityAgreement(f.scan, f.left, f.right, rig, rig.T_cam_lidar);
  std::cout << std::fixed << std::setprecision(4) << dir << "\n"
            << "  layout "
            << (seq.layout() == tescalib::KittiLayout::kOdometry ? "odometry" : "raw") << ", "
            << seq.size() << " frames, " << kf.size() << " keyframes (>= 0.5 s apart), "
            << rig.left.width << "x" << rig.left.height << ", fx " << rig.left.fx << ", baseline "
            << rig.baseline() << " m\n"
            << (seq.incompleteFrames().empty()
                    ? ""
                    : "  note: frames left out, their files or stamp incomplete (" +
                          seq.incompleteFrames() + ")\n")
            << "  the data's LiDAR extrinsic (frames as kitti_to_bag names them), "
            << tescalib::describeTransform("velo_link", "camera_color_left",
                                           rig.T_cam_lidar.inverse(), "    ")
            << "\n"
            << "  frame " << f.index << ": " << f.scan.size() << " LiDAR points, " << rings.size()
            << " rings\n"
            << "  LiDAR-predicted disparity vs images: " << agree.points << " textured points, "
            << 100.0 * agree.fraction_within_1px << " % agree within 1 px, best global shift "
            << agree.best_global_shift << " px\n";
}

/// The residual's samples of frame `f` (whose stereo cloud is `sc`) and of the frames after it,
/// `frames` frames in all (fewer when the sequence has fewer); `last` gets the last one's id.
std::vector<tescalib::DisparitySample> pooledSamples(const tescalib::KittiSequence& seq,
                                                     const tescalib::Frame& f,
                                                     const tescalib::StereoCloud& sc, int frames,
                                                     int* last) {
  const tescalib::StereoRig& rig = seq.rig();
  std::vector<tescalib::DisparitySample> out =
      tescalib::disparitySamples(f.scan, sc, rig.T_cam_lidar);
  *last = f.index;
  for (size_t i = 1; i < std::min(seq.size(), static_cast<size_t>(frames)); ++i) {
    const tescalib::Frame g = seq.load(i);
    const tescalib::StereoCloud c =
        tescalib::computeStereoCloud(g.left, g.right, rig, rig.T_right_left);
    const std::vector<tescalib::DisparitySample> more =
        tescalib::disparitySamples(g.scan, c, rig.T_cam_lidar);
    out.insert(out.end(), more.begin(), more.end());
    *last = g.index;
  }
  return out;
}

/// The residual by third of the image and by ring, and its fit against the disparity, over the
/// points of the first `frames` frames.
void printSignatures(const tescalib::KittiSequence& seq, const tescalib::Frame& f,
                     const tescalib::StereoCloud& sc, int frames) {
  int last = f.index;
  const std::vector<tescalib::DisparitySample> samples = pooledSamples(seq, f, sc, frames, &last);
  const tescalib::DisparitySignatures s = tescalib::disparitySignatures(samples);
  const int used = static_cast<int>(std::min(seq.size(), static_cast<size_t>(frames)));
  if (used > 1)
    std::cout << "  the next three lines pool frames " << f.index << "-" << last << " (" << used
              << " frames, " << s.points << " points)\n";
  std::cout << std::fixed << std::setprecision(3)
            << "  by column (left / middle / right third): " << std::showpos << s.third_median_px[0]
            << " / " << s.third_median_px[1] << " / " << s.third_median_px[2] << std::noshowpos
            << " px (" << s.third_points[0] << " / " << s.third_points[1] << " / "
            << s.third_points[2] << " points)\n"
            << "  by ring: ring-to-ring jump " << s.ring_jump_px << " px over " << s.rings
            << " rings (" << s.ring_pairs << " neighbouring pairs";
  if (s.ring_max_jump_ring >= 0)
    std::cout << ", largest " << s.ring_max_jump_px << " px between rings " << s.ring_max_jump_ring
              << " and " << s.ring_max_jump_ring + 1;
  std::cout << "; ring medians " << std::showpos << s.ring_min_median_px << " to "
            << s.ring_max_median_px << std::noshowpos << " px)\n"
            << "  measured disparity offset " << std::showpos << s.fit.offset_px << " px, scale "
            << 100 * s.fit.scale << std::noshowpos << " % (stereo minus LiDAR = offset + scale "
            << "x LiDAR disparity, Huber fit of " << s.fit.points << " points, spread "
            << s.fit.sigma_px << " px)\n"
            << std::setprecision(4);
}

/// The stereo pair at the data's calibration: SGBM against the LiDAR-predicted disparity by
/// depth and its signatures (over the first `frames` frames), the right image's rows against the
/// calibration, and the images' quality.
void printStereo(const tescalib::KittiSequence& seq, const tescalib::Frame& f, int frames) {
  const tescalib::StereoRig& rig = seq.rig();
  const tescalib::StereoCloud sc =
      tescalib::computeStereoCloud(f.left, f.right, rig, rig.T_right_left);
  const tescalib::VerticalAlignment va =
      tescalib::verticalAlignment(f.left, f.right, sc, rig, rig.T_right_left);
  const tescalib::DisparityResidual dr =
      tescalib::lidarDisparityResidual(f.scan, sc, rig.T_cam_lidar);
  std::cout << "  stereo (SGBM) minus LiDAR-predicted disparity at the dataset's calibration: "
            << dr.points << " points, median " << std::showpos << dr.median_px << " px;"
            << std::noshowpos;
  for (int b = 0; b < tescalib::DisparityResidual::kBins; ++b)
    std::cout << std::defaultfloat << " " << tescalib::DisparityResidual::kBinEdges[b] << "-"
              << tescalib::DisparityResidual::kBinEdges[b + 1] << " m: " << std::fixed
              << std::setprecision(3) << std::showpos << dr.bin_median_px[b] << std::noshowpos
              << " (" << dr.bin_points[b] << ")";
  std::cout << std::setprecision(4) << "\n";
  printSignatures(seq, f, sc, frames);
  std::cout << "  right-image rows vs the calibration (found - predicted v): " << va.points
            << " corners, median " << std::showpos << va.median_px << " px, fit " << va.offset_px
            << " " << va.slope_x_px << " x " << va.slope_y_px << " y px" << std::noshowpos
            << " (x, y normalised), spread " << va.spread_px << " px\n";
  if (va.points > 0 && std::fabs(va.median_px) > 0.25)
    std::cout << "  note: the rows disagree with the calibration by more than 0.25 px; SGBM "
                 "matches along rows, so the disparities of oblique texture are biased\n";
  tescalib::ImageQuality ql, qr;
  const std::string problem =
      tescalib::pairQualityProblem(f.left, f.right, tescalib::ImageQualitySettings{}, &ql, &qr);
  std::cout << std::setprecision(2) << "  frame " << f.index
            << " images, left / right: contrast (grey std dev) " << ql.contrast << " / "
            << qr.contrast << ", black or saturated " << 100 * ql.clipped_fraction << " / "
            << 100 * qr.clipped_fraction << " %; sharpness right / left "
            << qr.sharpness / std::max(ql.sharpness, 1e-9) << std::setprecision(4) << "\n";
  if (!problem.empty())
    std::cout << "  note: with the default images/ parameters the online node would refuse "
                 "this frame's pair: "
              << problem << "\n";
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app(kDescription, "tescalib_check_data");
  tescalib::cli::setUp(&app, kUsage, "Options");
  std::vector<std::string> dirs;
  int frames = 1;
  // Not ->required(): an unknown option alone is named as such, not as a missing DIR.
  app.add_option("DIR", dirs, "KITTI sequences")->type_name("");
  tescalib::cli::add(&app, "--frames", "N", tescalib::cli::to(&frames, tescalib::cli::atLeast(1)),
                     "the residual's signatures (by column, by ring, the offset and scale fit) "
                     "over the points of the first N frames of each sequence, or all when it has "
                     "fewer (default 1: frame 0 alone, the frame of the other lines)");
  if (argc < 2) {
    std::cout << app.help();
    return 2;
  }
  if (!tescalib::cli::parse(&app, argc, argv)) {
    std::cerr << "tescalib_check_data: --help lists the options\n";
    return 2;
  }
  if (dirs.empty()) {
    std::cerr << "tescalib_check_data: give at least one DIR (--help lists the options)\n";
    return 2;
  }
  int bad = 0;
  for (const std::string& dir : dirs) {
    try {
      const tescalib::KittiSequence seq(dir);
      const tescalib::Frame f = seq.load(0);
      printReader(dir, seq, f);
      printStereo(seq, f, frames);
    } catch (const tescalib::DataError& e) {
      std::cerr << "tescalib_check_data: " << e.what() << "\n";
      ++bad;
    }
  }
  return bad ? 1 : 0;
}
