// The core reports bad input with this exception type; tools and the ROS layer catch it and turn
// it into a clear message. It never escapes into the nodelet manager.
#pragma once

#include <stdexcept>
#include <string>

namespace tescalib {

/// Bad or unreadable input data. The message names the file (or item) and what is wrong.
class DataError : public std::runtime_error {
 public:
  explicit DataError(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace tescalib
