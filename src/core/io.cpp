// Format dispatch, atomic writes, landmark files, and the shared parsing helpers.
// The readers themselves are in io_surface.cpp and io_volume.cpp.
#include "shapemap/io.h"
#include "shapemap/geometry/tet_volume.h"
#include "io_detail.h"
#include <Eigen/Geometry>
#include <unistd.h>
#include <algorithm>
#include <map>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>

namespace fs = std::filesystem;

namespace shapemap {
namespace detail {

std::string quote(std::string_view tok) {
  std::string s = "'";
  size_t n = std::min<size_t>(tok.size(), 32);
  for (size_t i = 0; i < n; ++i) {
    unsigned char c = static_cast<unsigned char>(tok[i]);
    if (c >= 32 && c < 127) {
      s += char(c);
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      s += buf;
    }
  }
  if (tok.size() > n) s += "...";
  return s + "'";
}

std::string read_file_bytes(const std::string& path) {
  std::error_code ec;
  fs::file_status st = fs::status(path, ec);
  if (ec || !fs::exists(st)) throw InputError(path + ": cannot open (no such file)");
  if (fs::is_directory(st)) throw InputError(path + ": cannot open (is a folder)");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open (" + std::strerror(errno) + ")");
  std::string data;
  if (fs::is_regular_file(st)) {
    auto size = fs::file_size(path, ec);
    if (!ec) {
      // One read into place; a file that changed size meanwhile is read to its end below.
      data.resize(size_t(size));
      in.read(data.data(), std::streamsize(size));
      data.resize(size_t(in.gcount()));
      if (in.bad()) throw InputError(path + ": read error");
      if (!in) return data;
    }
  }
  // A pipe or device (process substitution <(...) is one) is read to its end, up to a bound
  // (a symlink to /dev/zero must not take all the memory).
  constexpr size_t kMaxStreamBytes = size_t(1) << 31;
  char buf[1 << 16];
  while (in.read(buf, sizeof buf) || in.gcount() > 0) {
    data.append(buf, size_t(in.gcount()));
    if (data.size() > kMaxStreamBytes) throw InputError(path + ": not a regular file and longer than 2 GiB");
  }
  if (in.bad()) throw InputError(path + ": read error");
  return data;
}

void write_bytes_atomic(const std::string& path, const std::string& bytes) {
  if (path.empty()) throw InputError("output file: empty path");
  static std::atomic<unsigned> counter{0};
  fs::path p(path);
  fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  std::string tmp = (dir / ("." + p.filename().string() + ".tmp-" + std::to_string(getpid()) + "-" +
                            std::to_string(counter++)))
                        .string();
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw InputError(path + ": cannot write (" + std::strerror(errno) + ")");
    out.write(bytes.data(), std::streamsize(bytes.size()));
    out.flush();
    if (!out) {
      out.close();
      std::error_code ec;
      fs::remove(tmp, ec);
      throw InputError(path + ": write failed (disk full?)");
    }
  }
  std::error_code ec;
  fs::rename(tmp, p, ec);
  if (ec) {
    std::error_code ec2;
    fs::remove(tmp, ec2);
    throw InputError(path + ": cannot write (" + ec.message() + ")");
  }
}

std::string extension(const std::string& path) {
  std::string name = fs::path(path).filename().string();
  size_t dot = name.rfind('.');
  if (dot == std::string::npos || dot == 0) return "";
  std::string e = name.substr(dot);
  for (char& c : e)
    if (c >= 'A' && c <= 'Z') c = char(c - 'A' + 'a');
  return e;
}

void orient_tets_positive(TetMesh& mesh) {
  // Serial: cheap, and no thread start-up for the many small files of the tests.
  Eigen::Index neg = 0, pos = 0;
  for (Eigen::Index t = 0; t < mesh.T.rows(); ++t) {
    Eigen::Vector3d a = mesh.V.row(mesh.T(t, 0)), b = mesh.V.row(mesh.T(t, 1)), c = mesh.V.row(mesh.T(t, 2)),
                    d = mesh.V.row(mesh.T(t, 3));
    const double v = signed_tet_volume6(a, b, c, d);
    neg += v < 0;
    pos += v > 0;
  }
  if (neg > pos)
    for (Eigen::Index t = 0; t < mesh.T.rows(); ++t) std::swap(mesh.T(t, 2), mesh.T(t, 3));
}

}  // namespace detail

using namespace detail;

void write_text_atomic(const std::string& path, const std::string& text) {
  write_bytes_atomic(path, text);
}

void write_binary_atomic(const std::string& path, const std::string& bytes) {
  write_bytes_atomic(path, bytes);
}

bool is_volume_path(const std::string& path) {
  std::string e = extension(path);
  return e == ".mesh" || e == ".vtk" || e == ".msh" || e == ".node" || e == ".ele";
}

bool is_surface_path(const std::string& path) {
  std::string e = extension(path);
  return e == ".obj" || e == ".off" || e == ".ply" || e == ".stl";
}

TriMesh read_surface(const std::string& path) {
  std::string e = extension(path);
  if (e == ".obj") return read_obj(path);
  if (e == ".off") return read_off(path);
  if (e == ".ply") return read_ply(path);
  if (e == ".stl") return read_stl(path);
  throw InputError(path + ": unknown surface format '" + e + "' (use .obj .off .ply .stl)");
}

// The writers' guard (the readers check what they read): V n×3, elements of k corners, every
// index in range. `what`, `E_name` and `indices` word the message.
static void check_writable(const std::string& path, const Eigen::MatrixXd& V, const Eigen::MatrixXi& E, int k,
                           const std::string& what, const std::string& E_name, const std::string& indices) {
  if (V.cols() != 3 || E.cols() != k)
    throw Error(path + ": cannot write a " + what + " with V " + std::to_string(V.cols()) + " columns and " +
                E_name + " " + std::to_string(E.cols()) + " columns");
  if (E.size() > 0 && (E.minCoeff() < 0 || E.maxCoeff() >= V.rows()))
    throw Error(path + ": cannot write a " + what + " with " + indices + " out of range");
}

static void check_writable(const std::string& path, const TriMesh& m) {
  check_writable(path, m.V, m.F, 3, "surface", "F", "face indices");
}

template <class Mesh>
using MeshWriter = void (*)(const std::string&, const Mesh&);

// Writes `mesh` with the writer of the path's extension (checked before anything else).
template <class Mesh>
static void write_by_extension(const std::string& path, const Mesh& mesh, const char* kind, const char* formats,
                               std::initializer_list<std::pair<const char*, MeshWriter<Mesh>>> writers) {
  const std::string e = extension(path);
  for (const auto& [ext, write] : writers)
    if (e == ext) {
      check_writable(path, mesh);
      return write(path, mesh);
    }
  throw InputError(path + ": unknown " + kind + " format '" + e + "' (use " + formats + ")");
}

void write_surface(const std::string& path, const TriMesh& mesh) {
  write_by_extension(path, mesh, "surface", ".obj .off .ply .stl",
                     {{".obj", write_obj}, {".off", write_off}, {".ply", write_ply}, {".stl", write_stl}});
}

TetMesh read_volume(const std::string& path) {
  std::string e = extension(path);
  TetMesh m;
  if (e == ".mesh")
    m = read_medit(path);
  else if (e == ".vtk")
    m = read_vtk(path);
  else if (e == ".msh")
    m = read_gmsh(path);
  else if (e == ".node" || e == ".ele")
    m = read_tetgen(path);
  else
    throw InputError(path + ": unknown volume format '" + e + "' (use .vtk .mesh .msh .node/.ele)");
  orient_tets_positive(m);
  return m;
}

static void check_writable(const std::string& path, const TetMesh& m) {
  check_writable(path, m.V, m.T, 4, "tet mesh", "T", "indices");
}

void write_volume(const std::string& path, const TetMesh& mesh) {
  auto vtk = [](const std::string& p, const TetMesh& m) { write_vtk(p, m); };
  write_by_extension(path, mesh, "volume", ".vtk .mesh .msh .node/.ele",
                     {{".vtk", vtk}, {".mesh", write_medit}, {".msh", write_gmsh}, {".node", write_tetgen},
                      {".ele", write_tetgen}});
}

void write_vtk(const std::string& path, const TetMesh& mesh,
               const std::vector<std::pair<std::string, Eigen::VectorXd>>& point_data,
               const std::vector<std::pair<std::string, Eigen::VectorXd>>& cell_data) {
  check_writable(path, mesh);
  const Eigen::Index n = mesh.V.rows(), m = mesh.T.rows();
  for (auto& d : point_data)
    if (d.second.size() != n)
      throw Error(path + ": point data '" + d.first + "' has " + std::to_string(d.second.size()) +
                  " values for " + std::to_string(n) + " vertices");
  for (auto& d : cell_data)
    if (d.second.size() != m)
      throw Error(path + ": cell data '" + d.first + "' has " + std::to_string(d.second.size()) +
                  " values for " + std::to_string(m) + " tets");
  std::string s;
  s.reserve(size_t(n) * 60 + size_t(m) * 40);
  s += "# vtk DataFile Version 3.0\nshapemap tetrahedral mesh\nASCII\nDATASET UNSTRUCTURED_GRID\n";
  s += "POINTS " + std::to_string(n) + " double\n";
  for (Eigen::Index i = 0; i < n; ++i) {
    for (int j = 0; j < 3; ++j) {
      if (j) s += ' ';
      append_double(s, mesh.V(i, j));
    }
    s += '\n';
  }
  s += "CELLS " + std::to_string(m) + " " + std::to_string(5 * m) + "\n";
  for (Eigen::Index t = 0; t < m; ++t) {
    s += '4';
    append_row(s, mesh.T, t);
    s += '\n';
  }
  s += "CELL_TYPES " + std::to_string(m) + "\n";
  for (Eigen::Index t = 0; t < m; ++t) s += "10\n";
  auto name_of = [](std::string name) {
    for (char& c : name)
      if (c == ' ' || c == '\t' || c == '\n' || c == '\r') c = '_';
    return name.empty() ? std::string("data") : name;
  };
  auto data = [&](const char* what, Eigen::Index count,
                  const std::vector<std::pair<std::string, Eigen::VectorXd>>& fields) {
    if (fields.empty()) return;
    s += std::string(what) + " " + std::to_string(count) + "\n";
    for (auto& f : fields) {
      s += "SCALARS " + name_of(f.first) + " double 1\nLOOKUP_TABLE default\n";
      for (Eigen::Index i = 0; i < count; ++i) {
        append_double(s, f.second(i));
        s += '\n';
      }
    }
  };
  data("POINT_DATA", n, point_data);
  data("CELL_DATA", m, cell_data);
  write_bytes_atomic(path, s);
}

Eigen::MatrixXd read_points(const std::string& path) {
  TextFile file(path);
  Parser& P = file.P;
  std::vector<double> xyz;
  while (P.more()) {
    for (const char* c : {"x", "y", "z"}) xyz.push_back(P.line_double(c));
    if (!P.at_eol()) P.fail("expected 3 values (x y z), found more");
    P.skip_line();
  }
  if (xyz.empty()) throw InputError(path + ": no points");
  return to_matrix(xyz, 3);
}

std::vector<int> read_landmarks(const std::string& path, const Eigen::MatrixXd& V,
                                const std::vector<int>& candidates) {
  const int n = int(V.rows());
  for (int c : candidates)
    if (c < 0 || c >= n)
      throw InputError(path + ": landmark candidate vertex " + std::to_string(c) + " out of range (" +
                       std::to_string(n) + " vertices)");
  TextFile file(path);
  Parser& P = file.P;
  std::vector<int> out;
  while (P.more()) {
    const int line = P.line();
    std::string_view tok[4];
    int k = 0;
    while (k < 4 && !P.at_eol()) tok[k++] = P.line_token();
    if (k == 1) {
      long long i = P.to_int(tok[0], "vertex index");
      if (i < 0 || i >= n)
        P.fail_at(line, "landmark vertex " + std::to_string(i) + " out of range (" + std::to_string(n) +
                            " vertices)");
      out.push_back(int(i));
    } else if (k == 3) {
      Eigen::RowVector3d x(P.to_double(tok[0], "x"), P.to_double(tok[1], "y"), P.to_double(tok[2], "z"));
      if (n == 0) P.fail_at(line, "no vertices to snap the landmark to");
      int best = -1;
      double bd = std::numeric_limits<double>::infinity();
      auto consider = [&](int v) {
        double d = (V.row(v) - x).squaredNorm();
        if (d < bd || best < 0) {
          bd = d;
          best = v;
        }
      };
      if (candidates.empty())
        for (int v = 0; v < n; ++v) consider(v);
      else
        for (int v : candidates) consider(v);
      out.push_back(best);
    } else {
      P.fail_at(line, "expected a vertex index or 'x y z', found " + std::to_string(k) +
                          (k == 4 ? " or more values" : " values"));
    }
    P.skip_line();
  }
  if (out.empty()) throw InputError(path + ": no landmarks");
  return out;
}

std::vector<std::string> tidy_landmark_pairs(std::vector<int>& LA, std::vector<int>& LB,
                                            const std::string& fileA, const std::string& fileB) {
  if (LA.size() != LB.size())
    throw InputError(fileB + ": " + std::to_string(LB.size()) + " landmarks, but " + fileA + " has " +
                     std::to_string(LA.size()));
  std::vector<std::string> notes;
  std::vector<int> a, b;
  std::map<std::pair<int, int>, size_t> seen;  // pair -> first line (0-based)
  int merged = 0;
  for (size_t k = 0; k < LA.size(); ++k) {
    const auto it = seen.find({LA[k], LB[k]});
    if (it != seen.end()) {
      ++merged;
      if (merged <= 3)
        notes.push_back(fileA + ", " + fileB + ": note: landmark pair " + std::to_string(k + 1) + " (vertices " +
                        std::to_string(LA[k]) + ", " + std::to_string(LB[k]) + ") repeats pair " +
                        std::to_string(it->second + 1) + ": kept once");
      continue;
    }
    seen[{LA[k], LB[k]}] = k;
    a.push_back(LA[k]);
    b.push_back(LB[k]);
  }
  if (merged > 3)
    notes.push_back(fileA + ", " + fileB + ": note: " + std::to_string(merged) + " repeated landmark pairs kept once in all");
  // A vertex with several partners (on either side): both pairs stay.
  for (int side = 0; side < 2; ++side) {
    const std::vector<int>& v = side == 0 ? a : b;
    std::map<int, int> count;
    for (int x : v) ++count[x];
    for (const auto& [x, c] : count)
      if (c > 1)
        notes.push_back((side == 0 ? fileA : fileB) + ": note: vertex " + std::to_string(x) + " has " +
                        std::to_string(c) + " different partners: all kept (soft constraints)");
  }
  LA.swap(a);
  LB.swap(b);
  return notes;
}

}  // namespace shapemap
