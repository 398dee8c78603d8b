// doc/parameters.md is checked against the shipped configuration: every key of config/kitti.yaml
// is a row of the user table with the config's default, and every key of config/expert.yaml
// appears in the expert table.
#include <algorithm>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

namespace {

std::string source(const std::string& path) {
  return std::string(TESCALIB_SOURCE_DIR) + "/" + path;
}

/// The scalar and sequence leaves of `node` as "a/b/c" -> the value as written (a sequence as
/// "[x, y]").
void flatten(const YAML::Node& node, const std::string& prefix,
             std::map<std::string, std::string>* out) {
  if (node.IsMap()) {
    for (const auto& kv : node)
      flatten(
          kv.second,
          prefix.empty() ? kv.first.as<std::string>() : prefix + "/" + kv.first.as<std::string>(),
          out);
  } else if (node.IsSequence()) {
    std::string joined;
    for (const auto& item : node) joined += (joined.empty() ? "" : ", ") + item.as<std::string>();
    (*out)[prefix] = "[" + joined + "]";
  } else {
    (*out)[prefix] = node.IsNull() ? "" : node.as<std::string>();
  }
}

/// The rows of the Markdown table under the heading that starts with `heading`: for each
/// parameter named in the first cell, the second cell; a cell naming several parameters gives
/// their defaults in the same order, separated by ", ".
std::map<std::string, std::string> tableRows(const std::string& doc, const std::string& heading) {
  std::map<std::string, std::string> rows;
  const size_t start = doc.find("\n" + heading);
  if (start == std::string::npos) return rows;
  const size_t end = doc.find("\n## ", start + 1);
  std::istringstream lines(doc.substr(start, end - start));
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("| `", 0) != 0) continue;
    const size_t first_end = line.find(" | ", 2);
    const std::string names = line.substr(2, first_end - 2);
    const size_t second_end = line.find(" | ", first_end + 3);
    const std::string value = line.substr(first_end + 3, second_end - first_end - 3);
    std::vector<std::string> named;
    for (size_t open = names.find('`'); open != std::string::npos;) {
      const size_t close = names.find('`', open + 1);
      named.push_back(names.substr(open + 1, close - open - 1));
      open = names.find('`', close + 1);
    }
    std::vector<std::string> values = {value};
    if (named.size() > 1) {
      values.clear();
      std::istringstream parts(value);
      for (std::string part; std::getline(parts, part, ',');)
        values.push_back(part.substr(part.find_first_not_of(' ')));
    }
    for (size_t i = 0; i < named.size(); ++i)
      rows[named[i]] = values[std::min(i, values.size() - 1)];
  }
  return rows;
}

std::string readAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Whether the table's default cell `cell` states the config's `value` (a number as written, or
/// "" for an empty string).
bool statesDefault(const std::string& cell, const std::string& value) {
  if (value.empty()) return cell.rfind("\"\"", 0) == 0;
  if (cell.rfind(value, 0) != 0) return false;
  // The value must end where a word ends: "10" is not "10.5" or "100".
  const char next = cell.size() > value.size() ? cell[value.size()] : ' ';
  return next == ' ' || next == ',' || next == ';';
}

}  // namespace

TEST(ParameterDocs, EveryUserParameterIsARowWithItsDefault) {
  std::map<std::string, std::string> config;
  flatten(YAML::LoadFile(source("config/kitti.yaml")), "", &config);
  ASSERT_GT(config.size(), 20u);
  const auto rows = tableRows(readAll(source("doc/parameters.md")), "## User parameters");
  ASSERT_GT(rows.size(), 20u);
  for (const auto& [key, value] : config) {
    const auto row = rows.find(key);
    if (row == rows.end()) {
      ADD_FAILURE() << key << " (config/kitti.yaml) has no row in doc/parameters.md's user table";
      continue;
    }
    EXPECT_TRUE(statesDefault(row->second, value))
        << key << ": config/kitti.yaml says '" << value << "', doc/parameters.md '" << row->second
        << "'";
  }
}

TEST(ParameterDocs, EveryExpertParameterIsInTheExpertTable) {
  std::map<std::string, std::string> config;
  flatten(YAML::LoadFile(source("config/expert.yaml")), "", &config);
  ASSERT_GT(config.size(), 20u);
  const std::string doc = readAll(source("doc/parameters.md"));
  const size_t expert = doc.find("\n## Expert");
  ASSERT_NE(expert, std::string::npos) << "doc/parameters.md has no expert section";
  const std::string section = doc.substr(expert);
  for (const auto& [key, value] : config) {
    // A row may name several parameters of one group: `lidar_stereo/a`, `b`.
    const std::string leaf = key.substr(key.rfind('/') + 1);
    EXPECT_TRUE(section.find("`" + key + "`") != std::string::npos ||
                section.find("`" + leaf + "`") != std::string::npos)
        << key << " (config/expert.yaml) is not in doc/parameters.md's expert table";
  }
}

TEST(ParameterDocs, TheDefaultCheckTellsValuesApart) {
  EXPECT_TRUE(statesDefault("10 keyframes", "10"));
  EXPECT_FALSE(statesDefault("100 keyframes", "10"));
  EXPECT_FALSE(statesDefault("10.5 s", "10"));
  EXPECT_TRUE(statesDefault("\"\" (string)", ""));
  EXPECT_FALSE(statesDefault("tescalib_left", ""));
}
