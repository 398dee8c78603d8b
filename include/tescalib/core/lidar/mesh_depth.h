// Z-buffer rendering of a LiDAR mesh into a camera: per pixel the nearest face and its depth.
// Used for key-point depth (paper eq. parametric_equation: a point on a face is a barycentric
// combination of its vertices) and for visibility checks between the two cameras.
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "tescalib/core/common/types.h"
#include "tescalib/core/lidar/lidar_mesh.h"

namespace tescalib {

struct MeshDepth {
  cv::Mat depth;    ///< CV_32F, camera z of the nearest face, +inf where no face
  cv::Mat face_id;  ///< CV_32S, index into mesh.faces, -1 where no face
};

/// Renders `mesh` (LiDAR frame) with `T_cam_lidar` into a camera with intrinsics `cam`.
MeshDepth renderMeshDepth(const LidarMesh& mesh, const Eigen::Isometry3d& T_cam_lidar,
                          const CameraIntrinsics& cam);

/// The 3D point (camera frame) where the ray of pixel (u, v) meets face `f`, i.e. the barycentric
/// combination of its vertices along that ray. False when the ray is parallel to the face.
bool intersectFace(const MeshFace& f, const Eigen::Isometry3d& T_cam_lidar,
                   const CameraIntrinsics& cam, double u, double v, Eigen::Vector3d* X);

enum class Visibility { kOutside, kOccluded, kVisible };

/// Whether the point `Y` (camera frame of `cam`) is seen by that camera: inside the image and not
/// behind the z-buffer `md` of the mesh rendered into it by more than `tolerance` (relative depth).
Visibility visibility(const Eigen::Vector3d& Y, const CameraIntrinsics& cam, const MeshDepth& md,
                      double tolerance);

}  // namespace tescalib
