// Rendered frames and written sequences of generated drives kept on disk for the gtests: a frame
// or a sequence one test binary generated is read back by the others (and by later runs) instead
// of being generated again.
// Rendering is most of a generated test's set-up time, and the scene generator is deterministic,
// so a stored frame is the frame a test would render itself (test_frame_cache checks that it is
// bit-identical).
//
// The frames live in the devel space's test_frames/ folder (make clean removes them), as
// test/generated_drive.py's drives of the rostests do, under a key made of every option that
// shapes the drive and of the bytes of the generator's libraries (libtescalib*.so): a rebuilt
// generator renders its frames anew, and the folders of other builds are removed. A frame is
// written to a temporary file and renamed into place, so a reader never sees a partial one;
// a file that does not read back whole is ignored and the frame rendered.
#pragma once

#include <dlfcn.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "tescalib/core/sim/simulator.h"

namespace tescalib_test {

namespace frame_cache_detail {

namespace fs = std::filesystem;

/// FNV-1a, 64 bit: a key, not a checksum against tampering.
inline uint64_t fnv1a(const void* data, size_t n, uint64_t h = 1469598103934665603ULL) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t k = 0; k < n; ++k) h = (h ^ p[k]) * 1099511628211ULL;
  return h;
}

inline std::string hex(uint64_t h) {
  std::ostringstream s;
  s << std::hex << std::setw(16) << std::setfill('0') << h;
  return s.str();
}

/// The devel space's lib folder: where the generator's library was loaded from.
inline fs::path libraryFolder() {
  Dl_info info{};
  if (!dladdr(reinterpret_cast<void*>(&tescalib::defaultSimCalib), &info) || !info.dli_fname)
    return {};
  return fs::absolute(info.dli_fname).parent_path();
}

/// Hash of the bytes of every libtescalib*.so next to the generator's library ("" if none).
inline std::string librariesHash(const fs::path& lib_dir) {
  std::vector<fs::path> libs;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(lib_dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("libtescalib", 0) == 0 && e.path().extension() == ".so")
      libs.push_back(e.path());
  }
  if (libs.empty()) return "";
  std::sort(libs.begin(), libs.end());
  uint64_t h = fnv1a("", 0);
  std::vector<char> buf(1 << 20);
  for (const fs::path& lib : libs) {
    std::ifstream in(lib, std::ios::binary);
    while (in.read(buf.data(), buf.size()) || in.gcount() > 0)
      h = fnv1a(buf.data(), in.gcount(), h);
  }
  return hex(h);
}

/// The folder of this build's frames (created; other builds' folders removed), "" when there is
/// no devel space to keep them in.
inline std::string buildFolder() {
  static std::once_flag once;
  static std::string folder;
  std::call_once(once, [] {
    const fs::path lib_dir = libraryFolder();
    const std::string libs = lib_dir.empty() ? "" : librariesHash(lib_dir);
    if (libs.empty()) return;
    const fs::path root = lib_dir.parent_path() / "test_frames";
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(root, ec))
      if (e.path().filename() != libs) fs::remove_all(e.path(), ec);
    fs::create_directories(root / libs, ec);
    if (!ec) folder = (root / libs).string();
  });
  return folder;
}

template <typename M>
void putMatrix(std::ostream& o, const M& m) {
  for (int r = 0; r < m.rows(); ++r)
    for (int c = 0; c < m.cols(); ++c) o << m(r, c) << " ";
}

#if defined(__x86_64__) && defined(__GLIBCXX__)
// optionsText names every field of SimOptions but threads: a field added there belongs in it too.
static_assert(sizeof(tescalib::SimOptions) == 976,
              "SimOptions changed: add its new field to the frame cache's optionsText");
#endif

/// Every option that shapes a drive's frames, as text (threads does not: a frame is the same on
/// any number of threads).
inline std::string optionsText(const tescalib::SimOptions& o) {
  std::ostringstream s;
  s << std::setprecision(17) << tescalib::sim::scenarioName(o.scenario) << " " << o.frames << " "
    << o.seed << " " << tescalib::noiseLevelName(o.noise) << " ";
  for (const auto& P : o.calib.P) putMatrix(s, P);
  putMatrix(s, o.calib.Tr);
  putMatrix(s, o.calib.R_right_left);
  s << o.width << " " << o.height << " " << o.left_gain << " " << o.left_offset << " "
    << o.right_gain << " " << o.right_offset << " " << o.write_every << " " << o.lidar_sweep << " ";
  putMatrix(s, o.T_vehicle_lidar.matrix());
  s << o.rig_source << " " << o.step.at_s << " " << o.step.rot_deg << " " << o.step.trans_m << " "
    << o.step.stereo << " " << o.realism_name << " " << o.realism.yaml();
  return s.str();
}

constexpr uint64_t kMagic = 0x3165726d61726674ULL;  // "tframe1e"

template <typename T>
void put(std::ostream& o, const T& v) {
  o.write(reinterpret_cast<const char*>(&v), sizeof(v));
}
template <typename T>
bool get(std::istream& in, T* v) {
  return bool(in.read(reinterpret_cast<char*>(v), sizeof(*v)));
}

inline void putImage(std::ostream& o, const cv::Mat& m) {
  const cv::Mat c = m.isContinuous() ? m : m.clone();
  put(o, int32_t(c.rows)), put(o, int32_t(c.cols)), put(o, int32_t(c.type()));
  o.write(reinterpret_cast<const char*>(c.data), std::streamsize(c.total() * c.elemSize()));
}

inline bool getImage(std::istream& in, cv::Mat* m) {
  int32_t rows = 0, cols = 0, type = 0;
  if (!get(in, &rows) || !get(in, &cols) || !get(in, &type) || rows < 0 || cols < 0) return false;
  *m = cv::Mat(rows, cols, type);
  return bool(
      in.read(reinterpret_cast<char*>(m->data), std::streamsize(m->total() * m->elemSize())));
}

inline bool writeFrame(const std::string& path, const tescalib::Frame& f) {
  std::ostringstream tmp_name;
  tmp_name << path << ".writing." << getpid() << "." << std::hash<std::string>()(path);
  {
    std::ofstream o(tmp_name.str(), std::ios::binary);
    put(o, kMagic), put(o, int32_t(f.index)), put(o, f.stamp), put(o, uint64_t(f.scan.size()));
    o.write(reinterpret_cast<const char*>(f.scan.data()),
            std::streamsize(f.scan.size() * sizeof(tescalib::LidarPoint)));
    putImage(o, f.left), putImage(o, f.right);
    put(o, kMagic);
    if (!o) {
      std::error_code ec;
      fs::remove(tmp_name.str(), ec);
      return false;
    }
  }
  std::error_code ec;
  fs::rename(tmp_name.str(), path, ec);
  if (ec) fs::remove(tmp_name.str(), ec);
  return !ec;
}

inline bool readFrame(const std::string& path, tescalib::Frame* f) {
  std::ifstream in(path, std::ios::binary);
  uint64_t magic = 0, points = 0;
  int32_t index = -1;
  if (!get(in, &magic) || magic != kMagic || !get(in, &index) || !get(in, &f->stamp) ||
      !get(in, &points) || points > (uint64_t(1) << 28))
    return false;
  f->index = index;
  f->scan.resize(points);
  if (!in.read(reinterpret_cast<char*>(f->scan.data()),
               std::streamsize(points * sizeof(tescalib::LidarPoint))))
    return false;
  return getImage(in, &f->left) && getImage(in, &f->right) && get(in, &magic) && magic == kMagic;
}

}  // namespace frame_cache_detail

/// Where frame `i` of the drive of `options` is stored ("" when there is no devel space).
inline std::string cachedFramePath(const tescalib::SimOptions& options, int i) {
  namespace d = frame_cache_detail;
  const std::string folder = d::buildFolder();
  if (folder.empty()) return "";
  const std::string text = d::optionsText(options);
  return folder + "/" + d::hex(d::fnv1a(text.data(), text.size())) + "_" + std::to_string(i) +
         ".frame";
}

/// Frame `i` of `sim`'s drive: read back when stored, else rendered and stored.
inline tescalib::Frame cachedFrame(const tescalib::Simulator& sim, int i) {
  const std::string path = cachedFramePath(sim.options(), i);
  tescalib::Frame f;
  if (!path.empty() && frame_cache_detail::readFrame(path, &f)) return f;
  f = sim.renderFrame(i);
  if (!path.empty()) frame_cache_detail::writeFrame(path, f);
  return f;
}

/// Writes `sim`'s sequence (Simulator::writeSequence) to `dir`: a copy of the one stored with the
/// frames, written there first when no test has stored it yet.
inline void writeCachedSequence(const tescalib::Simulator& sim, const std::string& dir) {
  namespace fs = frame_cache_detail::fs;
  const std::string frame0 = cachedFramePath(sim.options(), 0);
  if (frame0.empty()) return sim.writeSequence(dir);
  const std::string stored = frame0.substr(0, frame0.rfind('_')) + "_sequence";
  std::error_code ec;
  if (!fs::exists(fs::path(stored) / "sim_info.txt")) {
    const std::string writing = stored + ".writing." + std::to_string(getpid());
    sim.writeSequence(writing);
    fs::rename(writing, stored, ec);  // fails when another test stored it meanwhile
    if (ec) fs::remove_all(writing, ec);
  }
  fs::create_directories(dir);
  fs::copy(stored, dir, fs::copy_options::recursive | fs::copy_options::overwrite_existing);
}

}  // namespace tescalib_test
