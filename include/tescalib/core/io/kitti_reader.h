// Reader for KITTI sequences in the odometry layout and in the raw layout (ROS-free).
//
// Odometry layout (also what tescalib_simulate writes):
//   DIR/calib.txt (P0..P3, Tr), DIR/times.txt, DIR/image_2/NNNNNN.png, DIR/image_3/NNNNNN.png,
//   DIR/velodyne/NNNNNN.bin
// Raw layout (a drive folder, calibration in the drive folder or its parent date folder):
//   calib_cam_to_cam.txt, calib_velo_to_cam.txt, image_02/data/*.png, image_03/data/*.png,
//   velodyne_points/data/*.bin, image_02/timestamps.txt
//
// Only frames whose three files all exist are listed. The calibration files: kitti_calib.h; the
// scans: velodyne_bin.h.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "tescalib/core/common/types.h"
#include "tescalib/core/io/kitti_calib.h"
#include "tescalib/core/io/velodyne_bin.h"

namespace tescalib {

enum class KittiLayout { kOdometry, kRaw };

/// An opened KITTI sequence: its rig and the list of frames present on disk.
class KittiSequence {
 public:
  /// Opens DIR, detecting the layout. Throws DataError with a clear message on any problem
  /// (missing/malformed calibration, no frames, images of the wrong size).
  explicit KittiSequence(const std::string& dir);

  const std::string& dir() const { return dir_; }
  KittiLayout layout() const { return layout_; }
  const StereoRig& rig() const { return rig_; }
  /// The calibration as the dataset gives it (raw layout: P_rect_0N and Tr = R_rect_00 * velo ->
  /// cam0), e.g. for writing camera_info as kitti2bag does; rig() is derived from it.
  const KittiOdometryCalib& calib() const { return calib_; }
  size_t size() const { return frame_ids_.size(); }
  int frameId(size_t i) const { return frame_ids_[i]; }
  double stamp(size_t i) const { return stamps_[i]; }

  /// Loads frame i (scan with rings, both images as BGR). Throws DataError on a bad file.
  Frame load(size_t i) const;
  /// Loads only the LiDAR scan of frame i.
  LidarScan loadScan(size_t i) const;

  /// Whether the scans are raw sweeps that need de-skewing: KITTI raw recordings (their readme:
  /// the points must be "untwisted"), tescalib_simulate output written with --lidar-sweep 1.
  /// Not KITTI odometry sequences: KITTI compensated their scans for the ego-motion (odometry
  /// readme), nor the generator's default output (every beam from the pose at the stamp).
  bool sweptScans() const;

  /// Frames left out because one of their files or their stamp is missing: "" when every
  /// left image, right image and scan has the other two and a stamp, otherwise what each source
  /// holds ("12 left images, 10 right images, 12 scans; 2 frames without a stamp").
  const std::string& incompleteFrames() const { return incomplete_; }

  /// Indices of keyframes at least `min_dt` seconds apart (first frame always taken).
  std::vector<size_t> keyframes(double min_dt = 0.5) const;

  /// File paths of frame i.
  std::string leftPath(size_t i) const;
  std::string rightPath(size_t i) const;
  std::string velodynePath(size_t i) const;

 private:
  void openOdometry();
  void openRaw();
  void checkImageSizes();
  void noteIncomplete(size_t left, size_t right, size_t scans, size_t complete);

  std::string dir_;
  KittiLayout layout_ = KittiLayout::kOdometry;
  KittiOdometryCalib calib_;
  StereoRig rig_;
  std::vector<int> frame_ids_;
  std::vector<double> stamps_;
  int name_digits_ = 6;
  std::string incomplete_;
};

/// Opens sequences that form one calibration window: throws DataError when one cannot be opened
/// or its rig differs from the first one's (extrinsics by more than 1e-4, either camera's
/// intrinsics by more than 1e-3 px, or the image size).
std::vector<std::unique_ptr<KittiSequence>> openSequences(const std::vector<std::string>& dirs);

}  // namespace tescalib
