// A bag's sensor_msgs/CompressedImage (image_transport's `compressed`: PNG or JPEG of the image)
// as the sensor_msgs/Image the calibrator reads, so that the offline tools calibrate recordings
// whose cameras were recorded compressed.
#pragma once

#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

namespace tescalib {

/// The decoded image with the message's header: bgr8 (colour), bgra8, mono8 or mono16, as the
/// compressed data holds it; null when the data is not an image OpenCV can decode (empty,
/// truncated, compressedDepth).
sensor_msgs::Image::ConstPtr decodeCompressedImage(const sensor_msgs::CompressedImage& msg);

}  // namespace tescalib
