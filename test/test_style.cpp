// Every C++ file of the package is formatted with the committed .clang-format (STYLE.md, 11).
// Checked with Debian 12's clang-format 14, which the files are formatted with; other versions
// format some constructs differently, so the check skips (with a message) when clang-format is
// missing or is another version.
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>

#include "run_command.h"

namespace fs = std::filesystem;

namespace {

/// The clang-format major version on PATH, or 0 when there is none.
int clangFormatMajor() {
  std::string out;
  if (tescalib_test::runCommand("clang-format --version", &out) != 0) return 0;
  std::smatch m;
  return std::regex_search(out, m, std::regex(R"(version (\d+)\.)")) ? std::stoi(m[1]) : 0;
}

/// Whether clang-format with the package's .clang-format leaves `file` as it is; `report` gets
/// the first lines clang-format would change.
bool isFormatted(const fs::path& file, std::string* report) {
  const fs::path style = fs::path(TESCALIB_SOURCE_DIR) / ".clang-format";
  const int rc = tescalib_test::runCommand("clang-format --style=file:'" + style.string() +
                                               "' --dry-run --Werror '" + file.string() + "'",
                                           report);
  if (report->size() > 600) report->resize(600);
  return rc == 0;
}

constexpr int kCheckedMajor = 14;

}  // namespace

TEST(Style, EveryCppFileIsClangFormatted) {
  const int major = clangFormatMajor();
  if (major != kCheckedMajor)
    GTEST_SKIP() << (major == 0 ? std::string("clang-format is not installed")
                                : "clang-format " + std::to_string(major) + " is not " +
                                      std::to_string(kCheckedMajor) + ", which the files follow");
  int files = 0;
  for (const char* sub : {"include", "src", "test"}) {
    for (const auto& e : fs::recursive_directory_iterator(fs::path(TESCALIB_SOURCE_DIR) / sub)) {
      const std::string ext = e.path().extension().string();
      if (!e.is_regular_file() || (ext != ".cpp" && ext != ".h")) continue;
      ++files;
      std::string report;
      EXPECT_TRUE(isFormatted(e.path(), &report))
          << e.path().string() << " is not clang-formatted (make format fixes it):\n"
          << report;
    }
  }
  EXPECT_GT(files, 50);
}

TEST(Style, TheFormatCheckCatchesAnUnformattedFile) {
  if (clangFormatMajor() != kCheckedMajor) GTEST_SKIP() << "no clang-format " << kCheckedMajor;
  const fs::path dir = fs::temp_directory_path() / ("tescalib_style_" + std::to_string(getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "bad.cpp") << "int  f( ){return 1;}\n";
  std::ofstream(dir / "good.cpp") << "int f() { return 1; }\n";
  std::string report;
  EXPECT_FALSE(isFormatted(dir / "bad.cpp", &report));
  EXPECT_NE(report.find("clang-format"), std::string::npos) << report;
  EXPECT_TRUE(isFormatted(dir / "good.cpp", &report)) << report;
  fs::remove_all(dir);
}
