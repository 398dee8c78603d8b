// Every C++ file of the package is formatted with the committed .clang-format, and no file of the
// package carries development history (Style.NoFileCarriesDevelopmentHistory).
// Checked with Debian 12's clang-format 14, which the files are formatted with; other versions
// format some constructs differently, so the check skips (with a message) when clang-format is
// missing or is another version.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
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

// Development history belongs in git's log, not in the files: a comment, a help text or a page of
// doc/ says what the product does now. These markers betray a diary entry: a session or tracker
// issue number, a dated entry, an experiment undone.
const std::vector<std::regex>& historyPatterns() {
  static const auto icase = std::regex::ECMAScript | std::regex::icase;
  static const std::vector<std::regex> patterns = {
      std::regex(R"(\bsessions? \d+)", icase),
      std::regex(R"(\bsession-\d+)", icase),
      std::regex(R"(\bissues? #?\d+)", icase),
      std::regex(R"((^|[\s(\[])#\d+\b)", icase),
      // A date, unless it is followed by a time of day (a timestamp in data, KITTI's
      // timestamps.txt); a benchmark table's stamp names its commit on the same line.
      std::regex(R"(\b20\d\d-[01]\d-[0-3]\d\b(?! \d\d:\d\d))", icase),
      std::regex(R"(\btried\b.*\breverted\b)", icase),
      std::regex(R"(\bearlier version\b)", icase),
  };
  return patterns;
}

/// The first history marker on `line`, or "" when it has none.
std::string historyMarker(const std::string& line) {
  static const std::regex commit(R"(\bcommit\b)", std::regex::ECMAScript | std::regex::icase);
  const bool stamped = std::regex_search(line, commit);
  for (size_t i = 0; i < historyPatterns().size(); ++i) {
    std::smatch m;
    if (!std::regex_search(line, m, historyPatterns()[i])) continue;
    if (i == 4 && stamped) continue;  // a benchmark's stamp: date and commit
    return m.str();
  }
  return "";
}

/// Whether `file` holds text: no NUL byte in its first 8 KB.
bool isText(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::string head(8192, '\0');
  in.read(&head[0], static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<size_t>(in.gcount()));
  return head.find('\0') == std::string::npos;
}

/// Every line with a history marker in the text files under `root`, as "file:line: marker | text",
/// skipping the build folders and git's data.
std::vector<std::string> historyLines(const fs::path& root) {
  std::vector<std::string> hits;
  for (auto it = fs::recursive_directory_iterator(root); it != fs::recursive_directory_iterator();
       ++it) {
    const std::string name = it->path().filename().string();
    if (it->is_directory()) {
      if (name == "build" || name == ".devel" || name == ".git") it.disable_recursion_pending();
      continue;
    }
    const std::string rel = fs::relative(it->path(), root).generic_string();
    if (!it->is_regular_file() || name == ".git" || fs::file_size(it->path()) > (4u << 20) ||
        !isText(it->path()))
      continue;
    std::ifstream in(it->path());
    std::string line;
    for (int n = 1; std::getline(in, line); ++n) {
      const std::string marker = historyMarker(line);
      if (!marker.empty())
        hits.push_back(rel + ":" + std::to_string(n) + ": \"" + marker + "\" | " +
                       line.substr(0, 160));
    }
  }
  std::sort(hits.begin(), hits.end());
  return hits;
}

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

TEST(Style, NoFileCarriesDevelopmentHistory) {
  const std::vector<std::string> hits = historyLines(fs::path(TESCALIB_SOURCE_DIR));
  std::ostringstream report;
  for (const std::string& h : hits) report << "  " << h << "\n";
  EXPECT_TRUE(hits.empty()) << hits.size()
                            << " lines carry development history (a session or issue number, a "
                               "dated entry); say what the code does now, and leave the history "
                               "to git's log:\n"
                            << report.str();
}

TEST(Style, TheHistoryCheckCatchesAPlantedLine) {
  const fs::path dir = fs::temp_directory_path() / ("tescalib_history_" + std::to_string(getpid()));
  fs::create_directories(dir / "src");
  fs::create_directories(dir / "build");
  // The markers are assembled here so that this file does not carry them itself.
  const std::string session = std::string("sess") + "ion 12";
  const std::string issue = std::string("iss") + "ue " + "#" + "7";
  const std::string date = std::string("20") + "24-05-17";
  std::ofstream(dir / "src" / "planted.cpp") << "int f() { return 1; }\n"
                                             << "// Faster since " << session << ".\n"
                                             << "// Fixes " << issue << ".\n";
  std::ofstream(dir / "notes.md") << "## " << date << ": new solver\n"
                                  << "| table | " << date << ", commit 0123abc, 2 cores |\n"
                                  << "stamp " << date << " 13:02:25.964 of a KITTI frame\n";
  std::ofstream(dir / "build" / "log.txt") << session << "\n";  // build output is not checked
  const std::vector<std::string> hits = historyLines(dir);
  std::ostringstream all;
  for (const std::string& h : hits) all << h << "\n";
  ASSERT_EQ(hits.size(), 3u) << all.str();
  EXPECT_EQ(hits[0].rfind("notes.md:1: \"" + date + "\"", 0), 0u) << all.str();
  EXPECT_EQ(hits[1].rfind("src/planted.cpp:2: \"" + session + "\"", 0), 0u) << all.str();
  EXPECT_EQ(hits[2].rfind("src/planted.cpp:3: \"" + issue + "\"", 0), 0u) << all.str();
  fs::remove_all(dir);
}
