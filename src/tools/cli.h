// The command-line walk the tools share: "--key value" pairs, -h / --help, comma lists.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <functional>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace tescalib::cli {

/// "a,b,,c" -> {"a", "b", "c"}.
inline std::vector<std::string> splitList(const std::string& s, char sep = ',') {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, sep);)
    if (!item.empty()) out.push_back(item);
  return out;
}

/// The whole of `s` as an int / a double: "7.9", "3x" or "" throw std::invalid_argument (std::stoi
/// alone would take "7.9" as 7).
inline int toInt(const std::string& s) {
  size_t used = 0;
  const int v = std::stoi(s, &used);
  if (used != s.size()) throw std::invalid_argument(s);
  return v;
}
/// Finite only: "nan" and "inf" throw too (no option of the tools means either).
inline double toDouble(const std::string& s) {
  size_t used = 0;
  const double v = std::stod(s, &used);
  if (used != s.size() || !std::isfinite(v)) throw std::invalid_argument(s);
  return v;
}
/// A 0|1 switch: anything else throws.
inline int toSwitch(const std::string& s) {
  const int v = toInt(s);
  if (v != 0 && v != 1) throw std::invalid_argument(s);
  return v;
}
/// A value that must be >= 0 (the tools keep negative values as "the default").
inline double toNonNegative(const std::string& s) {
  const double v = toDouble(s);
  if (v < 0) throw std::invalid_argument(s);
  return v;
}

/// A seed: decimal digits only, at most 2^53 (a JSON reader's double holds it exactly); "-1"
/// (which std::stoull wraps to 2^64 - 1) or "1.5" throw std::invalid_argument.
inline uint64_t toSeed(const std::string& s) {
  if (s.empty() || s.find_first_not_of("0123456789") != std::string::npos)
    throw std::invalid_argument(s);
  const unsigned long long v = std::stoull(s);
  if (v > (1ULL << 53)) throw std::invalid_argument(s);
  return v;
}

/// The folder a file at `path` would go into, when that folder does not exist ("" otherwise, and
/// for a bare file name): a tool checks its output paths before the work.
inline std::string missingFolder(const std::string& path) {
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  return !folder.empty() && !std::filesystem::is_directory(folder) ? folder.string() : "";
}

/// Calls `option(key, value)` for every "--key value" pair of argv; -h / --help prints `usage`
/// and exits with 0. `option` returns false for a key it does not know; an exception from it
/// (std::stoi on "abc", or thrown for a value out of range) is a bad value. Every problem is
/// reported on stderr, prefixed with `tool`, and makes the result false.
inline bool parseOptions(
    int argc, char** argv, const char* tool, void (*usage)(),
    const std::function<bool(const std::string& key, const std::string& value)>& option) {
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    if (k == "-h" || k == "--help") {
      usage();
      std::exit(0);
    }
    if (i + 1 >= argc) {
      std::cerr << tool << ": " << k << " has no value, or is not an option (--help lists them)\n";
      return false;
    }
    const std::string v = argv[++i];
    try {
      if (!option(k, v)) {
        std::cerr << tool << ": unknown option " << k << "\n";
        return false;
      }
    } catch (const std::exception&) {
      std::cerr << tool << ": bad value '" << v << "' for " << k << "\n";
      return false;
    }
  }
  return true;
}

}  // namespace tescalib::cli
