// The package passes catkin_lint at its strictest level (-W2: errors, warnings and notices).
// catkin_lint names the package after its folder, so it checks a symlink called tescalib; the
// check skips (with a message) when catkin_lint is not installed (make test installs it).
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "run_command.h"

namespace fs = std::filesystem;

namespace {

bool haveCatkinLint() {
  std::string out;
  return tescalib_test::runCommand("catkin_lint --version", &out) == 0;
}

/// catkin_lint -W2 on `package_dir` seen through a folder named tescalib; its output.
std::string lint(const fs::path& package_dir, int* status) {
  const fs::path dir = fs::temp_directory_path() / ("tescalib_lint_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const fs::path link = dir / "tescalib";
  fs::remove(link);
  fs::create_directory_symlink(fs::absolute(package_dir), link);
  std::string out;
  // Without ROS_PACKAGE_PATH, which (in a sourced workspace) names the repository's own folder.
  *status = tescalib_test::runCommand(
      "env -u ROS_PACKAGE_PATH catkin_lint -W2 --strict '" + link.string() + "'", &out);
  fs::remove_all(dir);
  return out;
}

}  // namespace

TEST(Package, CatkinLintFindsNoProblem) {
  if (!haveCatkinLint()) GTEST_SKIP() << "catkin_lint is not installed (Debian: catkin-lint)";
  int status = -1;
  const std::string out = lint(TESCALIB_SOURCE_DIR, &status);
  EXPECT_EQ(status, 0) << out;
  EXPECT_NE(out.find("found 0 problems"), std::string::npos) << out;
}

TEST(Package, CatkinLintCatchesAMissingCatkinDepend) {
  if (!haveCatkinLint()) GTEST_SKIP() << "catkin_lint is not installed (Debian: catkin-lint)";
  const fs::path pkg = fs::temp_directory_path() / ("tescalib_badpkg_" + std::to_string(getpid()));
  fs::create_directories(pkg);
  std::ofstream(pkg / "package.xml")
      << "<?xml version=\"1.0\"?>\n<package format=\"3\"><name>tescalib</name>"
         "<version>0.1.0</version><description>d</description>"
         "<maintainer email=\"dev@example.org\">m</maintainer><license>BSD</license>"
         "<buildtool_depend>catkin</buildtool_depend><depend>std_srvs</depend></package>\n";
  std::ofstream(pkg / "CMakeLists.txt")
      << "cmake_minimum_required(VERSION 3.10)\nproject(tescalib)\n"
         "find_package(catkin REQUIRED COMPONENTS std_srvs)\ncatkin_package()\n";
  int status = -1;
  const std::string out = lint(pkg, &status);
  fs::remove_all(pkg);
  EXPECT_NE(status, 0) << out;
  EXPECT_NE(out.find("std_srvs"), std::string::npos) << out;
}
