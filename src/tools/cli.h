// The tools' command lines: CLI11 apps whose options read their values whole (whole numbers,
// finite numbers, 0|1 switches, comma lists), a help wrapped at 80 columns, and usage errors
// reported on stderr as "TOOL: reason".
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
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "tescalib/core/stereo/stereo_cloud.h"

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
/// A whole number >= `min`.
inline std::function<int(const std::string&)> atLeast(int min) {
  return [min](const std::string& s) {
    const int v = toInt(s);
    if (v < min) throw std::invalid_argument(s);
    return v;
  };
}
/// SGBM's aggregation paths (StereoSettings::sgbm_paths): 3, 5 or 8; anything else throws.
inline int toSgbmPaths(const std::string& s) {
  const int v = toInt(s);
  if (!tescalib::validSgbmPaths(v)) throw std::invalid_argument(s);
  return v;
}
/// The value as it is given (a name, a path).
inline std::string text(const std::string& s) { return s; }

/// An image topic option's setter: the topic itself, and its camera_info in the topic's folder.
inline std::function<void(const std::string&)> imageTopic(std::string* image, std::string* info) {
  return [image, info](const std::string& v) {
    *image = v;
    // image_transport's compressed topic lies below its image topic: camera_info beside that one.
    const std::string suffix = "/compressed";
    const bool compressed =
        v.size() > suffix.size() && v.compare(v.size() - suffix.size(), suffix.size(), suffix) == 0;
    const std::string base = compressed ? v.substr(0, v.size() - suffix.size()) : v;
    *info = base.substr(0, base.rfind('/') + 1) + "camera_info";
  };
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

/// `text` broken at spaces into lines of at most `width` characters; a longer word is broken
/// after a "::" (a C++ name), else keeps its own line. The text's own line breaks are kept.
inline std::string wrap(const std::string& text, size_t width) {
  std::string out;
  std::stringstream paragraphs(text);
  for (std::string paragraph; std::getline(paragraphs, paragraph);) {
    std::string line;
    std::stringstream words(paragraph);
    for (std::string word; words >> word;) {
      // Pieces of one word follow each other without a space.
      for (bool first_piece = true; !word.empty(); first_piece = false) {
        const size_t scope = word.find("::");
        const size_t cut =
            word.size() > width && scope != std::string::npos ? scope + 2 : word.size();
        const std::string piece = word.substr(0, cut);
        word.erase(0, cut);
        const size_t gap = line.empty() || !first_piece ? 0 : 1;
        if (!line.empty() && line.size() + gap + piece.size() > width) {
          out += line + "\n";
          line.clear();
        }
        line += (line.empty() || !first_piece ? "" : " ") + piece;
      }
    }
    out += line + "\n";
  }
  if (!out.empty()) out.pop_back();
  return out;
}

/// The help: the usage line (as it is given), the tool's description, the options by group (their
/// descriptions wrapped into the right-hand column) and the footer, all within 80 columns.
class HelpFormatter : public CLI::Formatter {
 public:
  static constexpr size_t kColumns = 80;
  explicit HelpFormatter(std::string usage) : usage_(std::move(usage)) { column_width(30); }
  std::string make_help(const CLI::App* app, std::string, CLI::AppFormatMode mode) const override {
    std::string help = usage_ + "\n" + wrap(app->get_description(), kColumns) + "\n" +
                       make_positionals(app) + make_groups(app, mode);
    if (!app->get_footer().empty()) help += "\n" + wrap(app->get_footer(), kColumns) + "\n";
    // One blank line between groups (CLI11 puts two).
    for (size_t at; (at = help.find("\n\n\n")) != std::string::npos;) help.erase(at, 1);
    return help;
  }
  std::string make_option_desc(const CLI::Option* opt) const override {
    return wrap(opt->get_description(), kColumns - get_column_width());
  }

 private:
  std::string usage_;
};

/// An app for `tool`: `usage` and `description` head its help, an option given twice takes its
/// last value, and -h / --help belongs to `help_group`.
inline void setUp(CLI::App* app, const std::string& usage, const std::string& help_group) {
  app->formatter(std::make_shared<HelpFormatter>(usage));
  app->option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
  app->get_help_ptr()->description("print this help and exit")->group(help_group);
}

/// The expert options of a tool: study switches of the method that a user never needs. They
/// are accepted on every command line; --help leaves them out (CLI11 hides options of the group
/// "") and --help-expert lists them, each group's name prefixed with "Expert: ".
class ExpertOptions {
 public:
  /// Adds --help-expert to `help_group` of `app`; `argc`/`argv` tell whether it is given.
  ExpertOptions(CLI::App* app, int argc, char** argv, const std::string& help_group) {
    for (int i = 1; i < argc; ++i) shown_ = shown_ || std::string(argv[i]) == "--help-expert";
    app->add_flag_callback(
           "--help-expert", [] { throw CLI::CallForHelp(); },
           "print this help with the expert options (studies of the method, which a user does "
           "not need) and exit")
        ->group(help_group);
  }
  /// The group an expert option of `name` goes into: hidden unless --help-expert is given.
  std::string group(const std::string& name) const { return shown_ ? "Expert: " + name : ""; }

 private:
  bool shown_ = false;
};

/// Adds the option `name` (a value named `value_name` in the help) whose value `set` takes: an
/// exception from it is "bad value 'VALUE' for NAME" unless it is a CLI::Error with its own
/// reason.
inline CLI::Option* add(CLI::App* app, const std::string& name, const std::string& value_name,
                        std::function<void(const std::string&)> set, const std::string& help) {
  auto callback = [name, set = std::move(set)](const std::string& value) {
    try {
      set(value);
    } catch (const CLI::Error&) {
      throw;
    } catch (const std::exception&) {
      throw CLI::ValidationError("bad value '" + value + "' for " + name);
    }
  };
  return app->add_option_function<std::string>(name, callback, help)->type_name(value_name);
}

/// A setter that stores `convert(value)` in *target.
template <class T, class Convert>
std::function<void(const std::string&)> to(T* target, Convert convert) {
  return [target, convert](const std::string& value) { *target = convert(value); };
}

/// Parses argv with `app`: -h / --help prints the help and exits with 0; a usage error (an unknown
/// option, a missing or bad value) is reported on stderr, prefixed with the tool's name, and
/// makes the result false.
inline bool parse(CLI::App* app, int argc, char** argv) {
  try {
    app->parse(argc, argv);
  } catch (const CLI::CallForHelp&) {
    std::cout << app->help();
    std::exit(0);
  } catch (const CLI::ParseError& e) {
    std::cerr << app->get_name() << ": " << e.what() << "\n";
    return false;
  }
  return true;
}

}  // namespace tescalib::cli
