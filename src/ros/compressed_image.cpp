#include "tescalib/ros/compressed_image.h"

#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/image_encodings.h>
#include <opencv2/imgcodecs.hpp>

namespace tescalib {

sensor_msgs::Image::ConstPtr decodeCompressedImage(const sensor_msgs::CompressedImage& msg) {
  if (msg.data.empty()) return nullptr;
  cv::Mat image;
  try {
    image = cv::imdecode(
        cv::Mat(1, static_cast<int>(msg.data.size()), CV_8U, const_cast<uint8_t*>(msg.data.data())),
        cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception&) {
    return nullptr;
  }
  namespace enc = sensor_msgs::image_encodings;
  std::string encoding;
  switch (image.empty() ? -1 : image.type()) {
    case CV_8UC1:
      encoding = enc::MONO8;
      break;
    case CV_8UC3:
      encoding = enc::BGR8;
      break;
    case CV_8UC4:
      encoding = enc::BGRA8;
      break;
    case CV_16UC1:
      encoding = enc::MONO16;
      break;
    default:
      return nullptr;
  }
  return cv_bridge::CvImage(msg.header, encoding, image).toImageMsg();
}

}  // namespace tescalib
