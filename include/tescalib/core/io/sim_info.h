// sim_info.txt, which tescalib_simulate writes beside a generated drive: "key: value" lines (the
// drive's parameters and its truth). ROS-free.
#pragma once

#include <map>
#include <string>

namespace tescalib {

/// The "key: value" lines of `dir`/sim_info.txt (values without trailing blanks; comments and
/// other lines skipped); empty when the folder has no such file.
std::map<std::string, std::string> readSimInfo(const std::string& dir);

}  // namespace tescalib
