#include "tescalib/core/io/sim_info.h"

#include <filesystem>
#include <fstream>

namespace tescalib {

std::map<std::string, std::string> readSimInfo(const std::string& dir) {
  std::map<std::string, std::string> info;
  std::ifstream in(std::filesystem::path(dir) / "sim_info.txt");
  std::string line;
  while (std::getline(in, line)) {
    const size_t colon = line.find(": ");
    if (line.empty() || line[0] == '#' || colon == std::string::npos) continue;
    std::string value = line.substr(colon + 2);
    value.erase(value.find_last_not_of(" \t\r") + 1);  // trailing blanks, a CRLF's CR
    info[line.substr(0, colon)] = value;
  }
  return info;
}

}  // namespace tescalib
