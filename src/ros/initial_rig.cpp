#include "tescalib/ros/initial_rig.h"

#include <algorithm>
#include <random>

#include <tf2_eigen/tf2_eigen.h>

#include "tescalib/core/common/geometry.h"
#include "tescalib/ros/conversions.h"

namespace tescalib {

Eigen::Isometry3d fromVector7(const std::vector<double>& v) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
  T.linear() = Eigen::Quaterniond(v[6], v[3], v[4], v[5]).normalized().toRotationMatrix();
  return T;
}

namespace {

/// tf2 refuses frame ids with a leading slash (tf1's convention, still in some drivers' messages);
/// tf2 and rviz drop it, and so does the node.
std::string tf2Frame(const std::string& frame) {
  const size_t first = frame.find_first_not_of('/');
  return first == std::string::npos ? "" : frame.substr(first);
}

/// Rectified images are what tescalib uses (it projects with P). A camera_info with distortion
/// comes with raw images from a driver, but also with stereo_image_proc's image_rect (which keeps
/// the raw camera's info) and with kitti2bag's rectified images: say it, do not refuse.
std::string distortionWarning(const sensor_msgs::CameraInfo& left_info,
                              const sensor_msgs::CameraInfo& right_info) {
  const auto distorted = [](const sensor_msgs::CameraInfo& info) {
    return std::any_of(info.D.begin(), info.D.end(), [](double d) { return d != 0.0; });
  };
  if (!distorted(left_info) && !distorted(right_info)) return "";
  return "the camera_info has lens distortion (D is not zero): tescalib projects with P and takes "
         "the images as rectified. stereo_image_proc's image_rect(_color) and kitti2bag's images "
         "are; a camera driver's image_raw is not: remap left/image_raw and right/image_raw to "
         "the rectified topics";
}

/// tescalib works in the rectified frame P describes. ROS's convention puts the unrectified
/// optical frame on tf, R rotating it into the rectified one; kitti2bag's bags put the rectified
/// frame on tf and KITTI's R_rect_0N into R. Both are taken as they come; say so.
std::string rectificationWarning(const sensor_msgs::CameraInfo& left_info,
                                 const std::string& left_frame) {
  Eigen::Matrix3d R;
  for (int i = 0; i < 9; ++i) R(i / 3, i % 3) = left_info.R[i];
  const double deg = R.isZero() ? 0.0 : Eigen::AngleAxisd(R).angle() * kDegPerRad;
  if (deg <= 0.01) return "";
  char text[700];
  std::snprintf(
      text, sizeof(text),
      "the left camera_info's R is a rotation of %.2f deg: the calibration is relative to the "
      "rectified left camera (the frame P describes, published as '%s'), and the initial guess "
      "from tf is taken as that frame's. If your tf frame is the unrectified optical one "
      "(stereo_image_proc), the guess is %.2f deg off (the solver corrects that) and "
      "T_optical_lidar = R^T T_cam_lidar; kitti2bag's frames are the rectified ones already",
      deg, left_frame.c_str(), deg);
  return text;
}

/// T_cam_lidar from tf; false with what to do about it.
bool initialFromTf(const NodeParams& params, const sensor_msgs::CameraInfo& left_info,
                   const std::string& lidar_frame, const tf2_ros::Buffer& tf, double tf_timeout,
                   Eigen::Isometry3d* T_cam_lidar, std::string* error) {
  const bool from_info = params.initial_tf_camera_frame.empty();
  const std::string camera_frame =
      tf2Frame(from_info ? left_info.header.frame_id : params.initial_tf_camera_frame);
  const std::string which =
      from_info ? "the left camera_info's frame_id" : "initial/tf_camera_frame";
  if (camera_frame.empty()) {
    *error =
        "no initial extrinsic: the left camera_info has no frame_id; name the left camera's tf "
        "frame with camera_frame:=FRAME (initial/tf_camera_frame) or set initial/T_cam_lidar";
    return false;
  }
  try {
    const auto t =
        tf.lookupTransform(camera_frame, lidar_frame, ros::Time(0), ros::Duration(tf_timeout));
    *T_cam_lidar = tf2::transformToEigen(t.transform);
    return true;
  } catch (const tf2::TransformException& ex) {
    *error = "no initial extrinsic: tf " + lidar_frame + " -> " + camera_frame + " (" + which +
             "): " + ex.what() +
             " (publish that transform, e.g. from the URDF or a static_transform_publisher; name "
             "another camera frame with camera_frame:=FRAME / initial/tf_camera_frame; or set "
             "initial/T_cam_lidar)";
    return false;
  }
}

}  // namespace

bool initialRig(const NodeParams& params, const sensor_msgs::PointCloud2& cloud,
                const sensor_msgs::CameraInfo& left_info, const sensor_msgs::CameraInfo& right_info,
                const tf2_ros::Buffer& tf, double tf_timeout, InitialRig* out, std::string* error) {
  *out = InitialRig{};
  StereoRig& rig = out->rig;
  if (!ros_conv::stereoFromCameraInfo(left_info, right_info, params.initial_T_right_left.empty(),
                                      &rig, error))
    return false;
  out->lidar_frame =
      tf2Frame(params.lidar_frame.empty() ? cloud.header.frame_id : params.lidar_frame);
  if (out->lidar_frame.empty()) {  // tf2 rejects an edge with an empty parent
    *error =
        "the point clouds have no frame_id and frames/lidar is not set: the estimate's tf would "
        "have no parent frame. Set frames/lidar to the LiDAR's frame";
    return false;
  }
  const std::string cloud_frame = tf2Frame(cloud.header.frame_id);
  if (!cloud_frame.empty() && out->lidar_frame != cloud_frame)
    out->warnings.push_back("frames/lidar '" + out->lidar_frame + "' is not the clouds' frame '" +
                            cloud_frame +
                            "': the clouds are taken to be in it as they are, not transformed "
                            "(right when the driver's frame_id names the same frame otherwise)");
  const std::string distortion = distortionWarning(left_info, right_info);
  if (!distortion.empty()) out->warnings.push_back(distortion);
  const std::string rectification = rectificationWarning(left_info, params.left_frame);
  if (!rectification.empty()) out->warnings.push_back(rectification);
  if (!params.initial_T_cam_lidar.empty())
    rig.T_cam_lidar = fromVector7(params.initial_T_cam_lidar);
  else if (!initialFromTf(params, left_info, out->lidar_frame, tf, tf_timeout, &rig.T_cam_lidar,
                          error))
    return false;
  // The node publishes lidar -> left -> right: a frame that already has a parent on tf (a URDF's
  // camera frame, the bag's own, the BASE_static_tf.launch of an earlier ~save) would get a
  // second one, and lookups would flip between them. Checked after the tf lookup above, which
  // waited for /tf_static on the first attempt.
  for (const auto& [name, frame] : {std::pair<std::string, std::string>{"left", params.left_frame},
                                    {"right", params.right_frame}}) {
    std::string parent;
    if (tf2Frame(frame) == out->lidar_frame) {
      *error = "frames/" + name + " '" + frame + "' is the LiDAR's frame: choose another name";
      return false;
    }
    // Above the LiDAR frame (its parent's parent, ...), the node's edge would close a loop.
    std::string above = out->lidar_frame;
    for (int depth = 0; depth < 64 && tf._getParent(above, ros::Time(0), parent); ++depth) {
      above = parent;
      if (above == tf2Frame(frame)) {
        *error = "frames/" + name + " '" + frame +
                 "' is above the LiDAR's frame on tf: the node's " + out->lidar_frame + " -> " +
                 frame + " would close a loop. Set frames/" + name +
                 " to a name nothing else publishes";
        return false;
      }
    }
    if (tf._getParent(tf2Frame(frame), ros::Time(0), parent)) {
      *error = "frames/" + name + " '" + frame + "' already has a parent on tf ('" + parent +
               "': a URDF's or the bag's frame, a BASE_static_tf.launch of an earlier ~save, or "
               "a bag recorded with this node's /tf_static?): the node would give it a second "
               "one. Stop that publisher, or set frames/" +
               name + " to a name nothing else publishes";
      return false;
    }
  }
  if (!params.initial_T_right_left.empty())
    rig.T_right_left = fromVector7(params.initial_T_right_left);
  if (params.initial_perturb_rot_deg > 0 || params.initial_perturb_trans_m > 0) {
    std::mt19937_64 rng(params.initial_perturb_seed);
    rig.T_cam_lidar =
        perturb(rig.T_cam_lidar, randomPerturbation(params.initial_perturb_rot_deg / kDegPerRad,
                                                    params.initial_perturb_trans_m, rng));
    char text[160];
    std::snprintf(text, sizeof(text),
                  "initial LiDAR extrinsic deliberately perturbed by %.2f deg / %.3f m",
                  params.initial_perturb_rot_deg, params.initial_perturb_trans_m);
    out->warnings.push_back(text);
  }
  return true;
}

}  // namespace tescalib
