#include "validate_bag.h"

#include <memory>

#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>

#include "tescalib/core/common/error.h"
#include "tescalib/core/online/online_settings.h"
#include "tescalib/ros/conversions.h"
#include "tescalib/ros/frame_intake.h"
#include "tescalib/ros/params.h"

namespace tescalib::validate {

BagRecording readBagRecording(const std::string& path, const BagTopics& topics,
                              const std::string& spec, const std::set<int>& numbers) {
  BagRecording out;
  tf2::BufferCore tf;
  readBagStaticTf(path, &tf);
  OnlineSettings online;
  online.keyframe_min_dt = spec == "keyframes" ? online.keyframe_min_dt : 0.0;
  std::unique_ptr<FrameIntake> intake;
  int index = 0;
  readBagSets(path, topics, [&](const BagSet& set) {
    if (!intake) {
      std::string error;
      if (!ros_conv::stereoFromCameraInfo(*set.left_info, *set.right_info, true, &out.rig, &error))
        throw DataError(path + ": " + error);
      out.rig.T_cam_lidar = bagLidarExtrinsic(path, tf, set);
      intake = std::make_unique<FrameIntake>(online, NodeParams().max_stereo_skew);
      intake->start(*set.left_info, *set.right_info);
    }
    const int i = index++;
    const IntakeResult r =
        intake->take(*set.cloud, *set.left, *set.left_info, *set.right, *set.right_info);
    if (r.outcome != IntakeOutcome::kCandidate) return;
    if (!numbers.empty() && !numbers.count(i)) return;
    out.frames.push_back(r.candidate.frame);
    out.labels.push_back("bag:" + std::to_string(i));
  });
  if (out.frames.empty())
    throw DataError(path + ": none of the frames --frames " + spec + " names");
  return out;
}

}  // namespace tescalib::validate
