// Shared fixtures of the io/checks/maps tests: a scratch folder, file helpers, small
// meshes built by hand.
#pragma once
#include "shapemap/error.h"
#include "shapemap/mesh.h"
#include <unistd.h>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

namespace shapemap::testing {

// A fresh folder in memory (/dev/shm) if possible, else under the system temp folder;
// removed at the end of the test binary. The fuzz tests write thousands of small files.
inline std::string scratch_dir() {
  static std::string dir = [] {
    std::error_code ec;
    std::filesystem::path base = std::filesystem::temp_directory_path();
    if (std::filesystem::is_directory("/dev/shm", ec) && access("/dev/shm", W_OK) == 0) base = "/dev/shm";
    auto d = base / ("shapemap-test-core-" + std::to_string(getpid()));
    std::filesystem::create_directories(d);
    static struct Cleanup {
      std::filesystem::path p;
      ~Cleanup() {
        std::error_code ec;
        std::filesystem::remove_all(p, ec);
      }
    } cleanup{d};
    return d.string();
  }();
  return dir;
}

inline std::string scratch(const std::string& name) { return scratch_dir() + "/" + name; }

inline void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), std::streamsize(bytes.size()));
}

inline std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Octahedron, outward oriented; coordinates not representable in float (0.1 steps)
// so text round trips are checked bit for bit.
inline TriMesh octahedron(double s = 1.1) {
  TriMesh m;
  m.V.resize(6, 3);
  m.V << s, 0, 0, -s, 0, 0, 0, s, 0, 0, -s, 0, 0, 0, s, 0, 0, -s;
  m.F.resize(8, 3);
  m.F << 0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5;
  return m;
}

// Torus of revolution, n x k quads split into triangles, outward oriented.
inline TriMesh torus(int n = 12, int k = 8, double R = 1.0, double r = 0.35) {
  TriMesh m;
  m.V.resize(n * k, 3);
  m.F.resize(2 * n * k, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < k; ++j) {
      double u = 2 * M_PI * i / n, v = 2 * M_PI * j / k;
      m.V.row(i * k + j) << (R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u), r * std::sin(v);
    }
  int f = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < k; ++j) {
      int a = i * k + j, b = ((i + 1) % n) * k + j, c = ((i + 1) % n) * k + (j + 1) % k, d = i * k + (j + 1) % k;
      m.F.row(f++) << a, b, c;
      m.F.row(f++) << a, c, d;
    }
  if (enclosed_volume(m.V, m.F) < 0)
    for (int i = 0; i < m.F.rows(); ++i) std::swap(m.F(i, 1), m.F(i, 2));
  return m;
}

// UV sphere-like closed genus-0 surface with about n*k vertices (poles + rings).
inline TriMesh uv_sphere(int rings = 6, int seg = 10, double radius = 1.0, Eigen::RowVector3d c = {0, 0, 0}) {
  TriMesh m;
  const int nv = 2 + rings * seg;
  m.V.resize(nv, 3);
  m.V.row(0) = c + Eigen::RowVector3d(0, 0, radius);
  m.V.row(nv - 1) = c + Eigen::RowVector3d(0, 0, -radius);
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < seg; ++j) {
      double th = M_PI * (i + 1) / (rings + 1), ph = 2 * M_PI * j / seg;
      m.V.row(1 + i * seg + j) =
          c + radius * Eigen::RowVector3d(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
    }
  std::vector<Eigen::RowVector3i> F;
  for (int j = 0; j < seg; ++j) F.push_back({0, 1 + j, 1 + (j + 1) % seg});
  for (int i = 0; i + 1 < rings; ++i)
    for (int j = 0; j < seg; ++j) {
      int a = 1 + i * seg + j, b = 1 + i * seg + (j + 1) % seg, cc = 1 + (i + 1) * seg + j,
          d = 1 + (i + 1) * seg + (j + 1) % seg;
      F.push_back({a, cc, d});
      F.push_back({a, d, b});
    }
  for (int j = 0; j < seg; ++j) F.push_back({nv - 1, 1 + (rings - 1) * seg + (j + 1) % seg, 1 + (rings - 1) * seg + j});
  m.F.resize(int(F.size()), 3);
  for (size_t i = 0; i < F.size(); ++i) m.F.row(int(i)) = F[i];
  if (enclosed_volume(m.V, m.F) < 0)
    for (int i = 0; i < m.F.rows(); ++i) std::swap(m.F(i, 1), m.F(i, 2));
  return m;
}

// Unit cube [0,1.1]^3 split into 6 positive tets around the diagonal 0-6.
inline TetMesh cube_tets(double s = 1.1) {
  TetMesh m;
  m.V.resize(8, 3);
  m.V << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1;
  m.V *= s;
  m.T.resize(6, 4);
  m.T << 0, 1, 2, 6, 0, 2, 3, 6, 0, 3, 7, 6, 0, 7, 4, 6, 0, 4, 5, 6, 0, 5, 1, 6;
  Eigen::VectorXd vol = tet_volumes(m.V, m.T);
  for (int t = 0; t < 6; ++t)
    if (vol(t) < 0) std::swap(m.T(t, 2), m.T(t, 3));
  return m;
}

// A 3x3x3 grid of cubes (64 vertices, 162 tets): a ball with interior vertices.
inline TetMesh grid_tets(int n = 3, double h = 0.3) {
  TetMesh m;
  const int p = n + 1;
  m.V.resize(p * p * p, 3);
  for (int i = 0; i < p; ++i)
    for (int j = 0; j < p; ++j)
      for (int k = 0; k < p; ++k) m.V.row((i * p + j) * p + k) << i * h, j * h, k * h;
  m.T.resize(6 * n * n * n, 4);
  static const int cube[6][4] = {{0, 1, 2, 6}, {0, 2, 3, 6}, {0, 3, 7, 6}, {0, 7, 4, 6}, {0, 4, 5, 6}, {0, 5, 1, 6}};
  int t = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) {
        auto id = [&](int a, int b, int c) { return ((i + a) * p + (j + b)) * p + (k + c); };
        int c8[8] = {id(0, 0, 0), id(1, 0, 0), id(1, 1, 0), id(0, 1, 0), id(0, 0, 1), id(1, 0, 1), id(1, 1, 1), id(0, 1, 1)};
        for (auto& q : cube) m.T.row(t++) << c8[q[0]], c8[q[1]], c8[q[2]], c8[q[3]];
      }
  Eigen::VectorXd vol = tet_volumes(m.V, m.T);
  for (int e = 0; e < m.T.rows(); ++e)
    if (vol(e) < 0) std::swap(m.T(e, 2), m.T(e, 3));
  return m;
}

// v's bytes appended to s in the given byte order (binary file formats).
template <class T>
void put(std::string& s, T v, bool big_endian) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  const std::uint16_t one = 1;
  bool host_be = *reinterpret_cast<const unsigned char*>(&one) == 0;
  if (big_endian != host_be)
    for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  s.append(reinterpret_cast<const char*>(b), sizeof(T));
}

// The message of the InputError that f throws, "(no error)" if none.
inline std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace shapemap::testing
