// The README's walk-through 2 runs as written: its commands are read from README.md and run (the
// tools from the devel space in place of `rosrun tescalib`, a temporary folder in place of /tmp),
// and the tool prints what the README shows.
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "run_command.h"
#include "test_util.h"

namespace {

std::string readmeText() {
  std::ifstream in(std::string(TESCALIB_SOURCE_DIR) + "/README.md");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// The code blocks (``` ... ```) of the README section whose heading starts with `heading`.
std::vector<std::string> codeBlocks(const std::string& readme, const std::string& heading) {
  std::vector<std::string> blocks;
  const size_t start = readme.find("\n" + heading);
  if (start == std::string::npos) return blocks;
  const size_t end = readme.find("\n## ", start + 1);
  const std::string section = readme.substr(start, end - start);
  for (size_t open = section.find("```"); open != std::string::npos;) {
    const size_t body = section.find('\n', open) + 1;
    const size_t close = section.find("```", body);
    if (close == std::string::npos) break;
    blocks.push_back(section.substr(body, close - body));
    open = section.find("```", close + 3);
  }
  return blocks;
}

/// The lines of `block` that start with `rosrun tescalib `, as commands of the devel space's
/// tools writing into `dir` instead of /tmp.
std::vector<std::string> toolCommands(const std::string& block, const std::string& dir) {
  std::vector<std::string> commands;
  std::istringstream lines(block);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("rosrun tescalib ", 0) != 0) continue;
    // The README's /tmp/ paths go to `dir`; the tool's own path (which may lie under /tmp) stays.
    const std::string args = std::regex_replace(line.substr(16), std::regex("/tmp/"), dir + "/");
    commands.push_back(std::string(TESCALIB_BIN_DIR) + "/" + args);
  }
  return commands;
}

/// The lines of the README's printout `shown` that `printed` does not hold, up to the figures
/// (which the README rounds from one run) and runs of blanks; lines with "..." are shortened ones.
std::vector<std::string> linesNotPrinted(const std::string& shown, const std::string& printed) {
  const std::regex figures("[-+]?[0-9]+(\\.[0-9]+)?"), blanks(" +");
  auto shape = [&](const std::string& text) {
    return std::regex_replace(std::regex_replace(text, figures, "#"), blanks, " ");
  };
  const std::string printed_shape = shape(printed);
  std::vector<std::string> missing;
  std::istringstream lines(shown);
  for (std::string line; std::getline(lines, line);)
    if (line.find("...") == std::string::npos &&
        printed_shape.find(shape(line)) == std::string::npos)
      missing.push_back(line);
  return missing;
}

}  // namespace

TEST(Readme, WalkThroughTwoRunsAsWritten) {
  const std::string readme = readmeText();
  const auto blocks = codeBlocks(readme, "## Walk-through 2");
  ASSERT_GE(blocks.size(), 2u) << "README.md: walk-through 2 with its commands and their output";
  tescalib_test::TempDir tmp;
  const auto commands = toolCommands(blocks[0], tmp.str());
  ASSERT_EQ(commands.size(), 2u) << blocks[0];
  std::string out;
  ASSERT_EQ(tescalib_test::runCommand(commands[0], &out), 0) << commands[0] << "\n" << out;
  ASSERT_EQ(tescalib_test::runCommand(commands[1], &out), 0) << commands[1] << "\n" << out;
  const std::string printed = std::regex_replace(out, std::regex(tmp.str() + "/"), "/tmp/");
  for (const std::string& line : linesNotPrinted(blocks[1], printed))
    ADD_FAILURE() << "README line not printed by the tool: " << line << "\n--- it printed:\n"
                  << out;
  for (const char* written : {"my_rig.yaml", "my_rig_calib.txt", "my_rig_static_tf.launch"})
    EXPECT_TRUE(tescalib_test::fs::exists(tmp.path / written)) << written;
}

TEST(Readme, TheWalkThroughCheckSeesAChangedCommand) {
  const std::string edited =
      "\n## Walk-through 2\n```\nrosrun tescalib tescalib_calibrate --bogus\n```\n";
  const auto blocks = codeBlocks(edited, "## Walk-through 2");
  ASSERT_EQ(blocks.size(), 1u);
  const auto commands = toolCommands(blocks[0], "/x");
  ASSERT_EQ(commands.size(), 1u);
  std::string out;
  EXPECT_NE(tescalib_test::runCommand(commands[0], &out), 0) << out;
  // A printout line the tool does not print is found; other figures are not a difference.
  const std::string printed =
      "estimate from 10 keyframes:\n  trusted: yes, every axis within 0.1 deg\n";
  EXPECT_TRUE(
      linesNotPrinted("estimate from 12 keyframes:\n  trusted:   yes, every axis within 0.2 deg",
                      printed)
          .empty());
  EXPECT_EQ(
      linesNotPrinted("  trusted: no\nestimate from 10 keyframes:\n  keyframe 3 ...", printed),
      std::vector<std::string>{"  trusted: no"});
}
