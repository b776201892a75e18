#include "common.h"
#include "shapemap/checks.h"
#include "shapemap/error.h"
#include "shapemap/io.h"
#include "shapemap/render/report_html.h"
#include <fcntl.h>
#include <sys/syscall.h>
#include <omp.h>
#include <sys/stat.h>
#include <unistd.h>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <mutex>

namespace fs = std::filesystem;

namespace shapemap::cli {

void apply_threads(const GlobalOptions& g) {
  if (g.threads > 0) omp_set_num_threads(g.threads);
}

ProgressCallback make_progress(const GlobalOptions& g) {
  if (g.quiet || !isatty(fileno(stderr))) return {};
  auto last = std::make_shared<std::pair<std::string, int>>("", -1);
  auto mtx = std::make_shared<std::mutex>();
  return [last, mtx](const std::string& stage, double f) {
    std::lock_guard<std::mutex> lock(*mtx);
    int pct = int(std::clamp(f, 0.0, 1.0) * 100);
    if (stage == last->first && pct == last->second) return;
    *last = {stage, pct};
    const int width = 30;
    int fill = pct * width / 100;
    std::fprintf(stderr, "\r%-28s [%s%s] %3d%%", stage.c_str(), std::string(fill, '#').c_str(),
                 std::string(width - fill, ' ').c_str(), pct);
    if (pct >= 100) std::fprintf(stderr, "\n");
    std::fflush(stderr);
  };
}

void info(const GlobalOptions& g, const std::string& msg) {
  if (!g.quiet) std::cerr << msg << "\n";
}

SurfaceRepair repair_input_surface(const TriMesh& mesh, const std::string& path, const GlobalOptions& g) {
  SurfaceRepairOptions o;
  o.strict = g.strict;
  SurfaceRepair r = repair_surface(mesh, path, o);
  for (const std::string& n : r.notes) info(g, n);
  return r;
}

TriMesh repaired_genus0_surface(const TriMesh& mesh, const std::string& path, const GlobalOptions& g,
                                std::vector<std::string>* notes) {
  SurfaceRepair r = repair_input_surface(mesh, path, g);
  require_genus0_surface(r.mesh, path);
  if (notes) notes->insert(notes->end(), r.notes.begin(), r.notes.end());
  return std::move(r.mesh);
}

TetMesh tetrahedralize_input(const TriMesh& surface, const TetrahedralizeOptions& opt,
                             const ProgressCallback& progress, const std::string& path, bool quiet) {
  TetrahedralizeInfo ti;
  TetMesh m;
  try {
    m = tetrahedralize(surface, opt, progress, &ti);
  } catch (const InputError& e) {
    // The library names the mesh "surface"; the user knows it by its path.
    const std::string msg = e.what(), prefix = "surface: ";
    throw InputError(path + ": " + (msg.compare(0, prefix.size(), prefix) == 0 ? msg.substr(prefix.size()) : msg));
  }
  if (!quiet)
    for (const std::string& n : tetrahedralize_notes(ti, path)) std::cerr << n << "\n";
  return m;
}

namespace {
// Temporary output folders of the running commands, removed when the process is
// interrupted (SIGINT, SIGTERM, SIGHUP), so that an interrupted run leaves nothing behind.
// The handler may interrupt any code, malloc included (a SIGTERM during CGAL's meshing
// deadlocked on the allocator's lock when the handler used nftw), so it uses only
// async-signal-safe calls (open, getdents64, unlinkat, close) and static buffers.
// OutputDirs are made by the main thread only.
constexpr int kTmpSlots = 8;
char g_tmp_path[kTmpSlots][4096];
std::atomic<bool> g_tmp_used[kTmpSlots];

constexpr int kMaxDepth = 8;  // output folders are at most a few levels deep
alignas(8) char g_dirents[kMaxDepth][8192];

struct LinuxDirent64 {  // the record getdents64 writes
  unsigned long long d_ino;
  long long d_off;
  unsigned short d_reclen;
  unsigned char d_type;
  char d_name[1];
};

// Removes everything inside the open directory dfd. Entries are removed while the
// directory is read, so it is read again from the start until a pass removes nothing.
void remove_contents(int dfd, int depth) {
  for (bool progress = true; progress;) {
    progress = false;
    ::lseek(dfd, 0, SEEK_SET);
    for (;;) {
      const long n = ::syscall(SYS_getdents64, dfd, g_dirents[depth], sizeof(g_dirents[depth]));
      if (n <= 0) break;
      for (long off = 0; off < n;) {
        const auto* d = reinterpret_cast<const LinuxDirent64*>(g_dirents[depth] + off);
        off += d->d_reclen;
        const char* name = d->d_name;
        if (name[0] == '.' && (name[1] == 0 || (name[1] == '.' && name[2] == 0))) continue;
        if (::unlinkat(dfd, name, 0) == 0) {
          progress = true;
          continue;
        }
        if (depth + 1 >= kMaxDepth) continue;
        const int sub = ::openat(dfd, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
        if (sub < 0) continue;
        remove_contents(sub, depth + 1);
        ::close(sub);
        if (::unlinkat(dfd, name, AT_REMOVEDIR) == 0) progress = true;
      }
    }
  }
}

extern "C" void remove_tmp_and_reraise(int sig) {
  const int saved_errno = errno;
  for (int i = 0; i < kTmpSlots; ++i) {
    if (!g_tmp_used[i].load()) continue;
    const int fd = ::open(g_tmp_path[i], O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0) continue;
    remove_contents(fd, 0);
    ::close(fd);
    ::rmdir(g_tmp_path[i]);
  }
  errno = saved_errno;
  // Default action on return: the signal is blocked in its handler, so raise() leaves it
  // pending until then, and the process ends with the signal's status.
  ::signal(sig, SIG_DFL);
  ::raise(sig);
}

int register_tmp(const std::string& path) {
  static std::once_flag handlers;
  std::call_once(handlers, [] {
    struct sigaction sa {};
    sa.sa_handler = remove_tmp_and_reraise;
    sigemptyset(&sa.sa_mask);  // the other two wait while one handler removes the folders
    for (int sig : {SIGINT, SIGTERM, SIGHUP}) sigaddset(&sa.sa_mask, sig);
    for (int sig : {SIGINT, SIGTERM, SIGHUP}) ::sigaction(sig, &sa, nullptr);
  });
  if (path.size() >= sizeof(g_tmp_path[0])) return -1;
  for (int i = 0; i < kTmpSlots; ++i)
    if (!g_tmp_used[i].load()) {
      std::strcpy(g_tmp_path[i], path.c_str());  // the path first, then the flag the handler reads
      g_tmp_used[i].store(true);
      return i;
    }
  return -1;
}

void unregister_tmp(int slot) {
  if (slot >= 0) g_tmp_used[slot].store(false);
}
}  // namespace

OutputDir::OutputDir(const std::string& final_path) : final_(final_path) {
  if (final_.empty()) throw InputError("output folder: empty path (use -o OUT)");
  while (final_.size() > 1 && final_.back() == '/') final_.pop_back();
  fs::path p(final_);
  if (fs::exists(p) && !fs::is_directory(p))
    throw InputError(final_ + ": exists and is not a folder");
  // The temporary folder goes into the nearest existing ancestor: a failed run must not
  // leave the missing parent folders of OUT behind (they are made at commit()).
  fs::path anc = p.has_parent_path() ? p.parent_path() : fs::path(".");
  while (!anc.empty() && !fs::exists(anc)) anc = anc.parent_path();
  if (anc.empty()) anc = ".";
  if (!fs::is_directory(anc)) throw InputError(final_ + ": cannot create output folder (" + anc.string() + " is a file)");
  std::error_code ec;
  tmp_ = (anc / ("." + p.filename().string() + ".tmp-" + std::to_string(getpid()))).string();
  fs::remove_all(tmp_, ec);
  if (!fs::create_directories(tmp_, ec) || ec)
    throw InputError(final_ + ": cannot create output folder (" + ec.message() + ")");
  slot_ = register_tmp(tmp_);
}

OutputDir::~OutputDir() {
  if (!committed_) {
    std::error_code ec;
    fs::remove_all(tmp_, ec);
  }
  unregister_tmp(slot_);
}

std::string OutputDir::path(const std::string& file) const {
  fs::path p = fs::path(tmp_) / file;
  std::error_code ec;
  fs::create_directories(p.parent_path(), ec);
  return p.string();
}

void OutputDir::commit() {
  fs::path dst(final_);
  std::error_code ec;
  if (dst.has_parent_path()) {
    fs::create_directories(dst.parent_path(), ec);
    if (ec) throw InputError(final_ + ": cannot create its parent folder (" + ec.message() + ")");
  }
  if (!fs::exists(dst)) {
    fs::rename(tmp_, dst, ec);
    if (ec) throw Error(final_ + ": cannot move output into place: " + ec.message());
  } else {
    // Move each produced file into the existing folder (replacing same-named files), after
    // checking that none of them would replace a folder: all files or none.
    std::vector<fs::path> files;
    for (auto& e : fs::recursive_directory_iterator(tmp_))
      if (e.is_regular_file()) files.push_back(fs::relative(e.path(), tmp_));
    for (const fs::path& rel : files) {
      fs::path at = dst;
      for (auto it = rel.begin(); it != rel.end(); ++it) {
        at /= *it;
        const bool last = std::next(it) == rel.end();
        if (fs::exists(at) && (last ? fs::is_directory(at) : !fs::is_directory(at)))
          throw InputError(at.string() + ": is in the way of an output " + (last ? "file" : "folder") +
                           "; nothing was written");
      }
    }
    for (const fs::path& rel : files) {
      fs::create_directories((dst / rel).parent_path(), ec);
      fs::rename(fs::path(tmp_) / rel, dst / rel, ec);
      if (ec) throw Error((dst / rel).string() + ": cannot move into place: " + ec.message());
    }
    fs::remove_all(tmp_, ec);
  }
  committed_ = true;
}

void StageTimer::start(const std::string& name) {
  if (!current_.empty()) stop();
  current_ = name;
  t0_ = std::chrono::steady_clock::now();
}

void StageTimer::stop() {
  if (current_.empty()) return;
  double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
  stages_.push_back({current_, s});
  current_.clear();
}

nlohmann::json StageTimer::json() const {
  nlohmann::json j = nlohmann::json::object();
  for (auto& [n, s] : stages_) j[n] = s;
  j["total"] = total();
  return j;
}

double StageTimer::total() const {
  double t = 0;
  for (auto& s : stages_) t += s.second;
  return t;
}

nlohmann::json report_header(const GlobalOptions& g, const std::string& command) {
  nlohmann::json j;
  j["tool"] = std::string("shapemap ") + SHAPEMAP_VERSION;
  j["command"] = command;
  j["seed"] = g.seed;
  j["threads"] = g.threads > 0 ? g.threads : omp_get_max_threads();
  return j;
}

void write_json(const std::string& path, const nlohmann::json& j) {
  write_text_atomic(path, j.dump(2) + "\n");
}

void write_reports(const OutputDir& out, const nlohmann::json& report, const std::string& title,
                   const std::vector<ReportFigure>& figures, const ViewerData* viewer, const GlobalOptions* g) {
  write_json(out.path("report.json"), report);
  std::vector<Figure> figs;
  for (auto& f : figures) {
    write_png(out.path(f.file), f.image);
    figs.push_back({f.caption, f.image});
  }
  if (viewer) {
    write_text_atomic(out.path("report_data.js"), viewer->script());
    write_text_atomic(out.path("report_viewer.js"), report_viewer_js());
    // Without three.js the page still opens and says why the 3D views are missing.
    if (!copy_three_js(out.path("three.min.js")) && g)
      info(*g, "note: three.min.js not found (install libjs-three or set SHAPEMAP_THREE_JS); report.html "
               "shows the pictures without the 3D views");
  }
  write_report_html(out.path("report.html"), title, report, figs, viewer != nullptr);
}

}  // namespace shapemap::cli
