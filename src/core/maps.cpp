// Barycentric vertex-to-point maps: positions, validation, and the map file format
// (docs/formats.md, "Map files").
#include "shapemap/maps.h"
#include <cstdio>
#include "io_detail.h"
#include "shapemap/error.h"
#include "shapemap/io.h"

namespace shapemap {

namespace {
// %.6g: "1e+308", not the 309 digits of std::to_string.
std::string short_number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", x);
  return buf;
}
}  // namespace

using namespace detail;

Eigen::MatrixXd map_positions(const BarycentricMap& map, const Eigen::MatrixXd& V,
                              const Eigen::MatrixXi& elements) {
  if (map.bary.rows() != map.elem.size() || map.bary.cols() != elements.cols())
    throw Error("map_positions: map of arity " + std::to_string(map.bary.cols()) + " on elements with " +
                std::to_string(elements.cols()) + " vertices");
  const Eigen::Index n = map.elem.size();
  Eigen::MatrixXd X(n, V.cols());
  int bad = 0;
#pragma omp parallel for schedule(static) reduction(max : bad)
  for (Eigen::Index i = 0; i < n; ++i) {
    int e = map.elem(i);
    if (e < 0 || e >= elements.rows()) {
      bad = 1;
      X.row(i).setZero();
      continue;
    }
    Eigen::RowVectorXd x = Eigen::RowVectorXd::Zero(V.cols());
    for (Eigen::Index j = 0; j < elements.cols(); ++j) x += map.bary(i, j) * V.row(elements(e, j));
    X.row(i) = x;
  }
  if (bad) throw Error("map_positions: element index out of range");
  return X;
}

void validate_map(const BarycentricMap& map, int num_source_vertices, int num_target_elements, int arity,
                  const std::string& name) {
  if (map.arity() != arity)
    throw InputError(name + ": map has " + std::to_string(map.arity()) + " barycentric coordinates per vertex, " +
                     "expected " + std::to_string(arity) + (arity == 3 ? " (a surface map)" : " (a volume map)"));
  if (map.size() != num_source_vertices || map.bary.rows() != map.elem.size())
    throw InputError(name + ": map has " + std::to_string(map.size()) + " entries, the source mesh has " +
                     std::to_string(num_source_vertices) + " vertices");
  const double tol = 1e-6;
  for (int i = 0; i < map.size(); ++i) {
    int e = map.elem(i);
    if (e < 0 || e >= num_target_elements)
      throw InputError(name + ": vertex " + std::to_string(i) + " maps to element " + std::to_string(e) +
                       ", out of range (" + std::to_string(num_target_elements) + " target elements)");
    double sum = 0;
    for (int j = 0; j < arity; ++j) {
      double b = map.bary(i, j);
      if (!std::isfinite(b))
        throw InputError(name + ": vertex " + std::to_string(i) + " has a non-finite barycentric coordinate");
      if (b < -tol)
        throw InputError(name + ": vertex " + std::to_string(i) + " has a negative barycentric coordinate (" +
                         short_number(b) + ")");
      sum += b;
    }
    if (std::abs(sum - 1.0) > tol)
      throw InputError(name + ": vertex " + std::to_string(i) + " has barycentric coordinates summing to " +
                       short_number(sum) + ", not 1");
  }
}

BarycentricMap read_map(const std::string& path) {
  TextFile file(path);
  Parser& P = file.P;
  if (!P.more()) P.fail("empty map file");
  std::string_view magic = P.line_token();
  if (magic != "shapemap-map") P.fail("not a shapemap map file (expected header 'shapemap-map 1 <n> <arity>', found " + quote(magic) + ")");
  long long version = P.line_int("format version");
  if (version != 1) P.fail("map format version " + std::to_string(version) + " is not supported (1)");
  long long n_raw = P.line_int("vertex count");
  long long arity = P.line_int("arity");
  if (arity != 3 && arity != 4) P.fail("arity " + std::to_string(arity) + " (need 3 for surfaces, 4 for volumes)");
  if (!P.at_eol()) P.fail("extra values after the header");
  P.skip_line();
  const int k = int(arity);
  const int n = P.check_count(n_raw, 2.0 * (k + 1), "map entry");
  BarycentricMap map;
  map.elem.resize(n);
  map.bary.resize(n, k);
  for (int i = 0; i < n; ++i) {
    P.skip_space();
    if (P.eof()) P.fail("file ends after " + std::to_string(i) + " of " + std::to_string(n) + " entries: truncated");
    long long e = P.line_int("element index");
    if (e < 0 || e > 2147483647LL) P.fail("element index " + std::to_string(e) + " out of range");
    map.elem(i) = int(e);
    for (int j = 0; j < k; ++j) map.bary(i, j) = P.line_double("barycentric coordinate");
    if (!P.at_eol()) P.fail("more than " + std::to_string(k + 1) + " values on an entry line");
    P.skip_line();
  }
  P.skip_space();
  if (!P.eof()) P.fail("more entries than the header's " + std::to_string(n));
  return map;
}

void write_map(const std::string& path, const BarycentricMap& map) {
  const int k = map.arity();
  if (k != 3 && k != 4) throw Error(path + ": cannot write a map of arity " + std::to_string(k));
  if (map.bary.rows() != map.elem.size()) throw Error(path + ": map with inconsistent sizes");
  std::string s;
  s.reserve(size_t(map.size()) * (12 + 24 * size_t(k)) + 300);
  s += "# shapemap map: one line per source vertex i (in order): target element index\n";
  s += k == 3 ? "# (triangle, 0-based) and 3 barycentric coordinates; point = sum_j b_j * V(F(elem, j))\n"
              : "# (tetrahedron, 0-based) and 4 barycentric coordinates; point = sum_j b_j * V(T(elem, j))\n";
  s += "shapemap-map 1 " + std::to_string(map.size()) + " " + std::to_string(k) + "\n";
  for (int i = 0; i < map.size(); ++i) {
    append_int(s, map.elem(i));
    for (int j = 0; j < k; ++j) {
      s += ' ';
      append_double(s, map.bary(i, j));
    }
    s += '\n';
  }
  write_text_atomic(path, s);
}

}  // namespace shapemap
