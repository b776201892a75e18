// Robustness of every reader: valid files of each format are truncated at many lengths
// and garbled at random (fixed seeds). Every variant must either read or throw
// InputError: no crash, no other exception, no hang, no huge allocation (the address
// space is capped at +1 GB during the test, so a reader that believed a garbled count
// would fail with bad_alloc and be reported).
#include "io_test_util.h"
#include "shapemap/error.h"
#include "shapemap/io.h"
#include "shapemap/maps.h"
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <functional>
#include <cstdio>
#include <random>

using namespace shapemap;
using namespace shapemap::testing;

namespace {

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif
#else
constexpr bool kSanitized = false;
#endif

size_t current_vm_bytes() {
  std::string status = read_bytes("/proc/self/status");
  size_t pos = status.find("VmSize:");
  if (pos == std::string::npos) return 0;
  return size_t(std::strtoull(status.c_str() + pos + 7, nullptr, 10)) * 1024;
}

// Caps the address space at its current size + extra while alive (not under ASan,
// which reserves terabytes of shadow memory).
struct AddressSpaceCap {
  rlimit old{};
  bool active = false;
  explicit AddressSpaceCap(size_t extra) {
    if (kSanitized || getrlimit(RLIMIT_AS, &old) != 0) return;
    size_t vm = current_vm_bytes();
    if (vm == 0) return;
    rlimit r = old;
    r.rlim_cur = rlim_t(vm + extra);
    if (old.rlim_max != RLIM_INFINITY && r.rlim_cur > old.rlim_max) return;
    active = setrlimit(RLIMIT_AS, &r) == 0;
  }
  ~AddressSpaceCap() {
    if (active) setrlimit(RLIMIT_AS, &old);
  }
};

struct FuzzStats {
  int variants = 0, accepted = 0, rejected = 0;
  std::vector<std::string> failures;
};

// Runs `read` on `path` after writing `bytes` there.
void try_variant(const std::string& path, const std::string& bytes, const std::function<void()>& read,
                 FuzzStats& st, const std::string& label) {
  write_file(path, bytes);
  ++st.variants;
  auto t0 = std::chrono::steady_clock::now();
  try {
    read();
    ++st.accepted;
  } catch (const InputError& e) {
    ++st.rejected;
    std::string msg = e.what();
    // One line, naming a file.
    if (msg.find('\n') != std::string::npos || msg.rfind(scratch_dir(), 0) != 0)
      st.failures.push_back(label + ": bad message: " + msg);
  } catch (const std::exception& e) {
    st.failures.push_back(label + ": " + typeid(e).name() + ": " + e.what());
  } catch (...) {
    st.failures.push_back(label + ": unknown exception");
  }
  double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (secs > 1.0) st.failures.push_back(label + ": took " + std::to_string(secs) + " s");
}

// Truncations at many lengths, random byte garbling, and injected huge numbers.
FuzzStats fuzz(const std::string& path, const std::string& valid, const std::function<void()>& read,
               std::uint32_t seed) {
  FuzzStats st;
  std::mt19937 rng(seed);
  const size_t n = valid.size();
  // Truncations: every length for small files, else 120 spread over the file.
  if (n <= 120) {
    for (size_t len = 0; len < n; ++len)
      try_variant(path, valid.substr(0, len), read, st, "truncated at " + std::to_string(len));
  } else {
    for (int k = 0; k < 120; ++k) {
      size_t len = size_t(double(k) / 120 * double(n));
      try_variant(path, valid.substr(0, len), read, st, "truncated at " + std::to_string(len));
    }
  }
  static const char palette[] = "0123456789-+.eE \n\t#$/\r";
  for (int k = 0; k < 200; ++k) {
    std::string g = valid;
    int changes = 1 + int(rng() % 4);
    for (int c = 0; c < changes; ++c) {
      size_t pos = rng() % n;
      g[pos] = (rng() % 2) ? char(rng() % 256) : palette[rng() % (sizeof(palette) - 1)];
    }
    try_variant(path, g, read, st, "garble " + std::to_string(k));
  }
  static const char* big[] = {"99999999999", "4294967295", "-1", "2147483647", "1e308", "nan", "-0", "1e999"};
  for (int k = 0; k < 50; ++k) {
    std::string g = valid;
    size_t pos = rng() % n;
    const char* b = big[rng() % 8];
    if (rng() % 2) {
      g.insert(pos, b);
    } else {
      // Replace a run of digits.
      size_t s = g.find_first_of("0123456789", pos);
      if (s == std::string::npos) s = pos;
      size_t e = g.find_first_not_of("0123456789", s);
      if (e == std::string::npos) e = g.size();
      g.replace(s, e - s, b);
    }
    try_variant(path, g, read, st, "number " + std::to_string(k));
  }
  // Binary counts garbled to huge values: set 4-byte windows to 0xff / 0x7f.
  for (int k = 0; k < 30; ++k) {
    std::string g = valid;
    size_t pos = rng() % n;
    for (size_t j = pos; j < std::min(n, pos + 4); ++j) g[j] = char(k % 2 ? 0xff : 0x7f);
    try_variant(path, g, read, st, "binary window " + std::to_string(k));
  }
  // Structural edits: delete, duplicate or move a random range of bytes.
  for (int k = 0; k < 40; ++k) {
    std::string g = valid;
    size_t a = rng() % n, len = 1 + rng() % std::max<size_t>(1, n / 8);
    len = std::min(len, n - a);
    std::string piece = g.substr(a, len);
    if (k % 3 == 0) {
      g.erase(a, len);
    } else if (k % 3 == 1) {
      g.insert(a, piece);
    } else {
      g.erase(a, len);
      g.insert(rng() % (g.size() + 1), piece);
    }
    try_variant(path, g, read, st, "splice " + std::to_string(k));
  }
  return st;
}

void report(const std::string& name, const FuzzStats& st) {
  std::printf("  fuzz %-16s %4d variants: %4d read, %4d rejected with InputError, %zu failures\n", name.c_str(),
              st.variants, st.accepted, st.rejected, st.failures.size());
  EXPECT_GT(st.variants, 300) << name;
  EXPECT_GT(st.rejected, 0) << name;
  for (size_t i = 0; i < std::min<size_t>(st.failures.size(), 8); ++i) ADD_FAILURE() << name << ": " << st.failures[i];
}

std::string ply_big_endian() {
  std::string s =
      "ply\nformat binary_big_endian 1.0\ncomment x\nelement vertex 4\nproperty float x\nproperty float y\n"
      "property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n";
  for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f}) put<float>(s, v, true);
  const int F[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  for (auto& f : F) {
    put<std::uint8_t>(s, 3, true);
    for (int v : f) put<std::int32_t>(s, v, true);
  }
  return s;
}

std::string vtk_binary() {
  std::string s = "# vtk DataFile Version 3.0\nb\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 5 float\n";
  const float P[5][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
  for (auto& r : P)
    for (float x : r) put<float>(s, x, true);
  s += "\nCELLS 2 10\n";
  for (int v : {4, 0, 1, 2, 3, 4, 1, 2, 4, 3}) put<std::int32_t>(s, v, true);
  s += "\nCELL_TYPES 2\n";
  for (int v : {10, 10}) put<std::int32_t>(s, v, true);
  s += "\n";
  return s;
}

}  // namespace

TEST(IOFuzz, SurfaceReadersNeverCrash) {
  AddressSpaceCap cap(size_t(1) << 30);
  std::printf("  address space capped at +1 GB during fuzzing: %s\n", cap.active ? "yes" : "no (sanitizer build)");
  if (cap.active) {  // the guard works: a 4 GB allocation fails instead of succeeding lazily
    auto huge = [] { return std::vector<char>(size_t(4) << 30).size(); };
    EXPECT_THROW(huge(), std::bad_alloc);
  }
  TriMesh m = octahedron();
  struct Case {
    std::string name, ext, bytes;
  };
  std::vector<Case> cases;
  for (const char* ext : {".obj", ".off", ".ply", ".stl"}) {
    std::string p = scratch(std::string("fuzz_valid") + ext);
    write_surface(p, m);
    cases.push_back({std::string("written ") + ext, ext, read_bytes(p)});
  }
  cases.push_back({"obj forms", ".obj",
                   "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvn 0 0 1\nf 1/1/1 3/1/1 2/1/1\nf 1//1 2//1 4//1\n"
                   "f -4 -1 -2\nf 2/1 3/1 4/1\n"});
  cases.push_back({"off colors", ".off",
                   "COFF\n# c\n4 4 6\n0 0 0 1 1 1 1\n1 0 0 1 1 1 1\n0 1 0 1 1 1 1\n0 0 1 1 1 1 1\n"
                   "3 0 2 1\n3 0 1 3\n3 0 3 2 255 0 0\n3 1 2 3\n"});
  cases.push_back({"ply ascii", ".ply",
                   "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                   "property uchar red\nelement face 4\nproperty list uchar int vertex_indices\nelement edge 1\n"
                   "property int a\nproperty int b\nend_header\n0 0 0 1\n1 0 0 1\n0 1 0 1\n0 0 1 1\n3 0 2 1\n3 0 1 3\n"
                   "3 0 3 2\n3 1 2 3\n0 1\n"});
  cases.push_back({"ply big endian", ".ply", ply_big_endian()});
  cases.push_back({"stl ascii", ".stl",
                   "solid t\nfacet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex 0 1 0\nvertex 1 0 0\nendloop\n"
                   "endfacet\nfacet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 0 1\nendloop\n"
                   "endfacet\nendsolid t\n"});
  std::uint32_t seed = 1;
  for (auto& c : cases) {
    std::string p = scratch("fuzz" + c.ext);
    FuzzStats st = fuzz(p, c.bytes, [&] { read_surface(p); }, seed++);
    report(c.name, st);
  }
}

TEST(IOFuzz, VolumeReadersNeverCrash) {
  AddressSpaceCap cap(size_t(1) << 30);
  TetMesh m = cube_tets();
  struct Case {
    std::string name, ext, bytes;
  };
  std::vector<Case> cases;
  for (const char* ext : {".vtk", ".mesh", ".msh"}) {
    std::string p = scratch(std::string("fuzz_valid") + ext);
    write_volume(p, m);
    cases.push_back({std::string("written ") + ext, ext, read_bytes(p)});
  }
  cases.push_back({"vtk binary", ".vtk", vtk_binary()});
  cases.push_back({"vtk 5.1", ".vtk",
                   "# vtk DataFile Version 5.1\nv\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 double\n0 0 0 1 0 0 "
                   "0 1 0 0 0 1\nMETADATA\nINFORMATION 0\n\nCELLS 2 4\nOFFSETS vtktypeint64\n0 4\nCONNECTIVITY "
                   "vtktypeint64\n0 1 2 3\nCELL_TYPES 1\n10\n"});
  cases.push_back({"gmsh 4.1", ".msh",
                   "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Entities\n0 0 0 1\n1 0 0 0 1 1 1 0 0\n$EndEntities\n"
                   "$Nodes\n1 4 1 4\n3 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n$EndNodes\n"
                   "$Elements\n1 1 1 1\n3 1 4 1\n1 1 2 3 4\n$EndElements\n"});
  std::uint32_t seed = 100;
  for (auto& c : cases) {
    std::string p = scratch("fuzz" + c.ext);
    FuzzStats st = fuzz(p, c.bytes, [&] { read_volume(p); }, seed++);
    report(c.name, st);
  }
  // TetGen: garble each of the two files with the other one valid.
  std::string node = scratch("fuzz_tg.node"), ele = scratch("fuzz_tg.ele");
  write_volume(node, m);
  std::string node_ok = read_bytes(node), ele_ok = read_bytes(ele);
  FuzzStats a = fuzz(node, node_ok, [&] { read_volume(ele); }, seed++);
  report("tetgen .node", a);
  write_file(node, node_ok);
  FuzzStats b = fuzz(ele, ele_ok, [&] { read_volume(node); }, seed++);
  report("tetgen .ele", b);
}

TEST(IOFuzz, MapAndLandmarkReadersNeverCrash) {
  AddressSpaceCap cap(size_t(1) << 30);
  BarycentricMap map;
  map.elem = Eigen::VectorXi::LinSpaced(6, 0, 5);
  map.bary = Eigen::MatrixXd::Constant(6, 3, 1.0 / 3.0);
  std::string p = scratch("fuzz_valid_map.txt");
  write_map(p, map);
  std::string q = scratch("fuzz_map.txt");
  report("map", fuzz(q, read_bytes(p), [&] { read_map(q); }, 7));
  TriMesh m = octahedron();
  std::string l = scratch("fuzz_landmarks.txt");
  report("landmarks", fuzz(l, "# landmarks\n0\n5\n1.0 0.5 -0.25\n3\n", [&] { read_landmarks(l, m.V); }, 8));
}
