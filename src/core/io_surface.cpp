// Surface readers and writers: OBJ, OFF, PLY (ASCII, binary little/big endian), STL
// (ASCII, binary). See docs/formats.md for the exact variants accepted.
#include "io_detail.h"
#include "shapemap/io.h"
#include <algorithm>
#include <array>
#include <cctype>
#include <unordered_map>

namespace shapemap::detail {

namespace {

// Collects vertices and fan-triangulated polygons, then checks and packs them.
struct SurfaceBuilder {
  std::vector<double> V;  // flat x y z
  std::vector<int> F;     // flat a b c
  int num_vertices() const { return int(V.size() / 3); }
  void add_vertex(double x, double y, double z) {
    V.push_back(x);
    V.push_back(y);
    V.push_back(z);
  }
  // Fan triangulation of a polygon (already 0-based and in range).
  void add_polygon(const std::vector<int>& poly) {
    for (size_t i = 1; i + 1 < poly.size(); ++i) {
      F.push_back(poly[0]);
      F.push_back(poly[i]);
      F.push_back(poly[i + 1]);
    }
  }
  TriMesh finish(const std::string& path) const {
    require_read(path, V, F, "faces");
    return {to_matrix(V, 3), to_matrix(F, 3)};
  }
};

std::string out_of_range(long long index, int n) {
  return "face index " + std::to_string(index) + " out of range (" + std::to_string(n) + " vertices)";
}

}  // namespace

// ---------------------------------------------------------------------------------
// OBJ: "v x y z [w|r g b]" and "f a b c ..." with a, a/t, a//n, a/t/n; negative
// indices count back from the last vertex read. Other statements are ignored; a line
// that does not start with a keyword (letters, digits, '_') is an error.
TriMesh read_obj(const std::string& path) {
  TextFile file(path);
  Parser& P = file.P;
  SurfaceBuilder S;
  // Positive indices may (in some writers) refer to vertices listed later, so they are
  // checked when the whole file is read.
  std::vector<int> face_line;
  std::vector<long long> raw;  // per triangle corner: 0-based index
  std::vector<long long> idx;
  while (!P.eof()) {
    if (P.at_eol()) {
      P.skip_line();
      continue;
    }
    std::string_view tok = P.line_token();
    if (tok == "v") {
      double x = P.line_double("vertex x");
      double y = P.line_double("vertex y");
      double z = P.line_double("vertex z");
      S.add_vertex(x, y, z);
    } else if (tok == "f" || tok == "fo") {
        idx.clear();
      while (!P.at_eol()) {
        std::string_view t = P.line_token();
        size_t slash = t.find('/');
        std::string_view head = t.substr(0, slash);
        long long i = P.to_int(head, "face vertex index");
        if (i == 0) P.fail("face index 0 (OBJ indices start at 1)");
        if (i < 0) {
          long long j = S.num_vertices() + i;
          if (j < 0) P.fail(out_of_range(i, S.num_vertices()));
          idx.push_back(j);
        } else {
          idx.push_back(i - 1);
        }
      }
      if (idx.size() < 3) P.fail("face with " + std::to_string(idx.size()) + " vertices (need at least 3)");
      for (size_t k = 1; k + 1 < idx.size(); ++k) {
        raw.push_back(idx[0]);
        raw.push_back(idx[k]);
        raw.push_back(idx[k + 1]);
        face_line.push_back(P.line());
      }
    } else if (tok.size() > 1 && (tok[0] == 'f' || tok[0] == 'v') &&
               (std::isdigit(static_cast<unsigned char>(tok[1])) || tok[1] == '-' || tok[1] == '.')) {
      // "f1 2 3", "v0.5 1 2": a statement fused with its first number would be dropped as
      // an unknown keyword (no OBJ keyword starts with f or v followed by a number).
      P.fail("not an OBJ statement: " + quote(tok) + " (missing space after '" + tok[0] + "'?)");
    } else if (!std::all_of(tok.begin(), tok.end(), [](char c) {
                 return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
               })) {
      // Other OBJ statements (vt, vn, g, usemtl, ...) are ignored, but a line that does
      // not start with a keyword at all is damage (e.g. "f" fused with its first index).
      P.fail("not an OBJ statement: line starts with " + quote(tok));
    }
    P.skip_line();
  }
  const int n = S.num_vertices();
  S.F.resize(raw.size());
  for (size_t k = 0; k < raw.size(); ++k) {
    if (raw[k] >= n) P.fail_at(face_line[k / 3], out_of_range(raw[k] + 1, n));
    S.F[k] = int(raw[k]);
  }
  return S.finish(path);
}

void write_obj(const std::string& path, const TriMesh& m) {
  std::string s;
  s.reserve(size_t(m.V.rows()) * 60 + size_t(m.F.rows()) * 30);
  s += "# shapemap\n";
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    s += 'v';
    append_row(s, m.V, i);
    s += '\n';
  }
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    s += 'f';
    append_row(s, m.F, f, 1);
    s += '\n';
  }
  write_bytes_atomic(path, s);
}

// ---------------------------------------------------------------------------------
// OFF: optional header [ST][C][N]OFF (counts may follow on the same line), '#'
// comments, "nv nf [ne]", nv vertex lines (x y z, extra values ignored), nf face
// lines "k i1 .. ik [color]" (0-based).
TriMesh read_off(const std::string& path) {
  TextFile file(path);
  Parser& P = file.P;
  std::string_view tok = P.next_token();
  if (tok.empty()) P.fail("empty file");
  bool numeric = tok.find_first_not_of("0123456789") == std::string_view::npos;
  if (!numeric) {
    bool ok = tok.size() >= 3 && iequals(tok.substr(tok.size() - 3), "OFF");
    std::string_view prefix = ok ? tok.substr(0, tok.size() - 3) : tok;
    if (ok) {
      for (char c : prefix) {
        if (c == '4' || c == 'n') P.fail("OFF variant " + quote(tok) + " (not 3D) is not supported");
        if (!(c == 'S' || c == 'T' || c == 'C' || c == 'N' || c == 's' || c == 't' || c == 'c')) ok = false;
      }
    }
    if (!ok) P.fail("not an OFF file (header " + quote(tok) + ", expected OFF)");
    if (iequals(P.peek_token(), "BINARY")) P.fail("binary OFF is not supported; save as ASCII OFF");
    tok = P.next_token();
  }
  const long long nv_raw = P.to_int(tok, "vertex count");
  const long long nf_raw = P.next_int("face count");
  if (!P.at_eol()) P.line_token();  // edge count, ignored
  const int nv = P.check_count(nv_raw, 6, "vertex");
  const int nf = P.check_count(nf_raw, 8, "face");
  P.skip_line();
  SurfaceBuilder S;
  S.V.reserve(size_t(nv) * 3);
  for (int i = 0; i < nv; ++i) {
    P.skip_space();
    double x = P.line_double("vertex x");
    double y = P.line_double("vertex y");
    double z = P.line_double("vertex z");
    S.add_vertex(x, y, z);
    P.skip_line();
  }
  std::vector<int> poly;
  S.F.reserve(size_t(nf) * 3);
  for (int f = 0; f < nf; ++f) {
    P.skip_space();
    long long k = P.line_int("face vertex count");
    if (k < 3) P.fail("face with " + std::to_string(k) + " vertices (need at least 3)");
    if (double(k) * 2 > double(P.remaining()) + 1) P.fail("face with " + std::to_string(k) + " vertices: truncated");
    poly.clear();
    for (long long j = 0; j < k; ++j) {
      long long i = P.line_int("face vertex index");
      if (i < 0 || i >= nv) P.fail(out_of_range(i, nv));
      poly.push_back(int(i));
    }
    S.add_polygon(poly);
    P.skip_line();
  }
  return S.finish(path);
}

void write_off(const std::string& path, const TriMesh& m) {
  std::string s;
  s.reserve(size_t(m.V.rows()) * 60 + size_t(m.F.rows()) * 30);
  s += "OFF\n" + std::to_string(m.V.rows()) + " " + std::to_string(m.F.rows()) + " 0\n";
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    for (int j = 0; j < 3; ++j) {
      if (j) s += ' ';
      append_double(s, m.V(i, j));
    }
    s += '\n';
  }
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    s += '3';
    append_row(s, m.F, f);
    s += '\n';
  }
  write_bytes_atomic(path, s);
}

// ---------------------------------------------------------------------------------
// PLY
namespace {

enum class PlyType { I8, U8, I16, U16, I32, U32, F32, F64 };

bool ply_type(std::string_view s, PlyType* t) {
  static const std::pair<const char*, PlyType> names[] = {
      {"char", PlyType::I8},    {"int8", PlyType::I8},     {"uchar", PlyType::U8},
      {"uint8", PlyType::U8},   {"short", PlyType::I16},   {"int16", PlyType::I16},
      {"ushort", PlyType::U16}, {"uint16", PlyType::U16},  {"int", PlyType::I32},
      {"int32", PlyType::I32},  {"uint", PlyType::U32},    {"uint32", PlyType::U32},
      {"float", PlyType::F32},  {"float32", PlyType::F32}, {"double", PlyType::F64},
      {"float64", PlyType::F64}};
  for (auto& n : names)
    if (s == n.first) {
      *t = n.second;
      return true;
    }
  return false;
}

size_t ply_size(PlyType t) {
  switch (t) {
    case PlyType::I8: case PlyType::U8: return 1;
    case PlyType::I16: case PlyType::U16: return 2;
    case PlyType::I32: case PlyType::U32: case PlyType::F32: return 4;
    case PlyType::F64: return 8;
  }
  return 1;
}

bool ply_integer(PlyType t) { return t != PlyType::F32 && t != PlyType::F64; }

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::F32;
  bool list = false;
  PlyType count_type = PlyType::U8;
};

struct PlyElement {
  std::string name;
  long long count = 0;
  int line = 0;
  std::vector<PlyProperty> props;
};

enum class PlyFormat { Ascii, BinaryLE, BinaryBE };

// Reads one value of type t (ASCII token or binary). Non-finite floats are returned
// as they are (only coordinates are required finite).
double ply_value(Parser& P, PlyFormat fmt, PlyType t, std::string_view what) {
  if (fmt == PlyFormat::Ascii) {
    std::string_view tok = P.next_token();
    if (ply_integer(t)) return double(P.to_int(tok, what));
    if (tok.empty()) P.fail("expected " + std::string(what) + ", found end of file");
    // Allow nan/inf in properties we skip; coordinates are checked by the caller.
    double x = 0;
    const char* s = tok.data();
    const char* e = s + tok.size();
    if (*s == '+') ++s;
    auto r = std::from_chars(s, e, x);
    if (r.ec == std::errc::invalid_argument || r.ptr != e) P.fail("expected " + std::string(what) + ", found " + quote(tok));
    if (r.ec == std::errc::result_out_of_range) P.fail(std::string(what) + " " + quote(tok) + " is out of range");
    return x;
  }
  bool be = fmt == PlyFormat::BinaryBE;
  switch (t) {
    case PlyType::I8: return P.read<std::int8_t>(be, what);
    case PlyType::U8: return P.read<std::uint8_t>(be, what);
    case PlyType::I16: return P.read<std::int16_t>(be, what);
    case PlyType::U16: return P.read<std::uint16_t>(be, what);
    case PlyType::I32: return P.read<std::int32_t>(be, what);
    case PlyType::U32: return P.read<std::uint32_t>(be, what);
    case PlyType::F32: return P.read<float>(be, what);
    case PlyType::F64: return P.read<double>(be, what);
  }
  return 0;
}

long long ply_index(Parser& P, PlyFormat fmt, PlyType t, std::string_view what) {
  double x = ply_value(P, fmt, t, what);
  if (!(std::isfinite(x) && x == std::floor(x) && std::abs(x) < 9e15))
    P.fail(std::string(what) + " is not an integer");
  return (long long)x;
}

}  // namespace

namespace {

// The PLY header up to end_header: the data format and the elements with their properties.
PlyFormat read_ply_header(Parser& P, std::vector<PlyElement>& elems) {
  std::string_view magic = P.rest_of_line();
  if (magic != "ply") P.fail_at(1, "not a PLY file (first line " + quote(magic) + ", expected 'ply')");
  PlyFormat fmt = PlyFormat::Ascii;
  bool have_format = false;
  for (;;) {
    if (P.eof()) P.fail("header has no end_header line");
    std::string_view kw = P.line_token();
    if (kw.empty()) {
      P.skip_line();
      continue;
    }
    if (kw == "end_header") {
      // Binary data starts right after this line's newline.
      P.rest_of_line();
      break;
    } else if (kw == "format") {
      std::string_view f = P.line_token();
      if (f == "ascii") fmt = PlyFormat::Ascii;
      else if (f == "binary_little_endian") fmt = PlyFormat::BinaryLE;
      else if (f == "binary_big_endian") fmt = PlyFormat::BinaryBE;
      else P.fail("unknown PLY format " + quote(f));
      have_format = true;
    } else if (kw == "comment" || kw == "obj_info") {
    } else if (kw == "element") {
      PlyElement e;
      e.name = std::string(P.line_token());
      if (e.name.empty()) P.fail("element without a name");
      e.count = P.line_int("element count");
      if (e.count < 0) P.fail("negative element count");
      e.line = P.line();
      elems.push_back(e);
    } else if (kw == "property") {
      if (elems.empty()) P.fail("property before any element");
      PlyProperty pr;
      std::string_view t = P.line_token();
      if (t == "list") {
        pr.list = true;
        std::string_view ct = P.line_token();
        if (!ply_type(ct, &pr.count_type) || !ply_integer(pr.count_type))
          P.fail("bad list count type " + quote(ct));
        t = P.line_token();
      }
      if (!ply_type(t, &pr.type)) P.fail("unknown property type " + quote(t));
      pr.name = std::string(P.line_token());
      if (pr.name.empty()) P.fail("property without a name");
      elems.back().props.push_back(pr);
    } else {
      P.fail("unknown header line " + quote(kw));
    }
    P.skip_line();
  }
  if (!have_format) P.fail("header has no format line");
  return fmt;
}

}  // namespace

TriMesh read_ply(const std::string& path) {
  std::string data = read_file_bytes(path);
  Parser P(path, data);
  std::vector<PlyElement> elems;
  const PlyFormat fmt = read_ply_header(P, elems);

  // ---- which properties we need
  const PlyElement* ve = nullptr;
  const PlyElement* fe = nullptr;
  for (auto& e : elems) {
    if (e.name == "vertex" && !ve) ve = &e;
    if (e.name == "face" && !fe) fe = &e;
  }
  if (!ve) throw InputError(path + ": no vertex element");
  if (!fe) throw InputError(path + ": no face element (a point cloud is not a surface)");
  int px = -1, py = -1, pz = -1, plist = -1;
  for (size_t i = 0; i < ve->props.size(); ++i) {
    if (ve->props[i].list) continue;
    if (ve->props[i].name == "x") px = int(i);
    if (ve->props[i].name == "y") py = int(i);
    if (ve->props[i].name == "z") pz = int(i);
  }
  if (px < 0 || py < 0 || pz < 0) P.fail_at(ve->line, "vertex element lacks an x, y or z property");
  for (size_t i = 0; i < fe->props.size(); ++i)
    if (fe->props[i].list && (fe->props[i].name == "vertex_indices" || fe->props[i].name == "vertex_index")) {
      plist = int(i);
      break;
    }
  if (plist < 0)
    for (size_t i = 0; i < fe->props.size(); ++i)
      if (fe->props[i].list) {
        plist = int(i);
        break;
      }
  if (plist < 0) P.fail_at(fe->line, "face element has no list property (vertex_indices)");
  const long long nv_ll = ve->count;

  // ---- data
  SurfaceBuilder S;
  std::vector<int> poly;
  const bool ascii = fmt == PlyFormat::Ascii;
  if (ascii) P.comment = 0;
  for (auto& e : elems) {
    if (e.props.empty()) continue;  // nothing to read, whatever the count
    double min_bytes = 0;
    for (auto& pr : e.props) min_bytes += ascii ? 2.0 : double(pr.list ? ply_size(pr.count_type) : ply_size(pr.type));
    const int count = P.check_count(e.count, min_bytes, "element '" + e.name + "'");
    const bool is_v = &e == ve, is_f = &e == fe;
    if (is_v) S.V.reserve(size_t(count) * 3);
    if (is_f) S.F.reserve(size_t(count) * 3);
    for (int i = 0; i < count; ++i) {
      double xyz[3] = {0, 0, 0};
      for (size_t k = 0; k < e.props.size(); ++k) {
        const PlyProperty& pr = e.props[k];
        if (!pr.list) {
          double x = ply_value(P, fmt, pr.type, pr.name);
          if (is_v) {
            int c = int(k) == px ? 0 : int(k) == py ? 1 : int(k) == pz ? 2 : -1;
            if (c >= 0) {
              if (!std::isfinite(x))
                P.fail("vertex " + std::to_string(i) + " " + pr.name + " is not finite" +
                       (ascii ? std::string() : " (byte offset " + std::to_string(P.offset()) + ")"));
              xyz[c] = x;
            }
          }
          continue;
        }
        long long len = ply_index(P, fmt, pr.count_type, "list length");
        if (len < 0) P.fail(e.name + " " + std::to_string(i) + ": negative list length");
        double item = ascii ? 2.0 : double(ply_size(pr.type));
        if (double(len) * item > double(P.remaining()) + 1)
          P.fail(e.name + " " + std::to_string(i) + ": list of " + std::to_string(len) +
                 " values does not fit in the rest of the file: truncated or corrupt");
        const bool keep = is_f && int(k) == plist;
        if (keep) {
          if (len < 3) P.fail("face " + std::to_string(i) + " with " + std::to_string(len) + " vertices (need at least 3)");
          poly.clear();
        }
        for (long long j = 0; j < len; ++j) {
          if (keep) {
            long long idx = ply_index(P, fmt, pr.type, "face vertex index");
            if (idx < 0 || idx >= nv_ll)
              P.fail("face " + std::to_string(i) + ": " + out_of_range(idx, int(std::min<long long>(nv_ll, 2147483647))) +
                     (ascii ? std::string() : " (byte offset " + std::to_string(P.offset()) + ")"));
            poly.push_back(int(idx));
          } else {
            ply_value(P, fmt, pr.type, "list value");
          }
        }
        if (keep) S.add_polygon(poly);
      }
      if (is_v) S.add_vertex(xyz[0], xyz[1], xyz[2]);
    }
  }
  return S.finish(path);
}

namespace {
template <class T>
void put_le(std::string& s, T v) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (Parser::host_big_endian())
    for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  s.append(reinterpret_cast<const char*>(b), sizeof(T));
}
}  // namespace

void write_ply(const std::string& path, const TriMesh& m) {
  std::string s;
  s.reserve(256 + size_t(m.V.rows()) * 24 + size_t(m.F.rows()) * 13);
  s += "ply\nformat binary_little_endian 1.0\ncomment shapemap\n";
  s += "element vertex " + std::to_string(m.V.rows()) + "\n";
  s += "property double x\nproperty double y\nproperty double z\n";
  s += "element face " + std::to_string(m.F.rows()) + "\n";
  s += "property list uchar int vertex_indices\nend_header\n";
  for (Eigen::Index i = 0; i < m.V.rows(); ++i)
    for (int j = 0; j < 3; ++j) put_le<double>(s, m.V(i, j));
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    put_le<std::uint8_t>(s, 3);
    for (int j = 0; j < 3; ++j) put_le<std::int32_t>(s, m.F(f, j));
  }
  write_bytes_atomic(path, s);
}

// ---------------------------------------------------------------------------------
// STL: binary if the size matches the triangle count of the header, else ASCII if it
// starts with "solid". Identical positions are merged (exact comparison).
namespace {

struct PositionKey {
  double x, y, z;
  bool operator==(const PositionKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct PositionHash {
  size_t operator()(const PositionKey& k) const {
    std::uint64_t h = 1469598103934665603ull;
    for (double d : {k.x, k.y, k.z}) {
      std::uint64_t b;
      std::memcpy(&b, &d, 8);
      h = (h ^ b) * 1099511628211ull;
      h ^= h >> 29;
    }
    return size_t(h);
  }
};

struct StlMerger {
  std::unordered_map<PositionKey, int, PositionHash> index;
  SurfaceBuilder S;
  int vertex(double x, double y, double z) {
    // +0 and -0 are the same position.
    PositionKey k{x == 0 ? 0.0 : x, y == 0 ? 0.0 : y, z == 0 ? 0.0 : z};
    auto it = index.find(k);
    if (it != index.end()) return it->second;
    int i = S.num_vertices();
    index.emplace(k, i);
    S.add_vertex(k.x, k.y, k.z);
    return i;
  }
};

bool starts_with_solid(const std::string& data) {
  size_t i = Parser::has_utf8_bom(data) ? 3 : 0;
  while (i < data.size() && (data[i] == ' ' || data[i] == '\t' || data[i] == '\r' || data[i] == '\n')) ++i;
  return data.size() - i >= 5 && iequals(std::string_view(data).substr(i, 5), "solid");
}

}  // namespace

TriMesh read_stl(const std::string& path) {
  std::string data = read_file_bytes(path);
  Parser P(path, data, /*skip_bom=*/false);  // a binary header may start with any bytes
  const size_t size = data.size();
  std::uint32_t n = 0;
  if (size >= 84) std::memcpy(&n, data.data() + 80, 4);
  if (Parser::host_big_endian()) n = (n >> 24) | ((n >> 8) & 0xff00u) | ((n << 8) & 0xff0000u) | (n << 24);
  const double expected = 84.0 + 50.0 * double(n);
  const bool solid = starts_with_solid(data);
  const bool binary = size >= 84 && (double(size) == expected || (!solid && double(size) > expected));
  StlMerger M;
  if (binary) {
    P.skip_bytes(84, "header");
    M.S.F.reserve(size_t(n) * 3);
    for (std::uint32_t t = 0; t < n; ++t) {
      P.skip_bytes(12, "normal");
      int c[3];
      for (int j = 0; j < 3; ++j) {
        float x = P.read<float>(false, "vertex"), y = P.read<float>(false, "vertex"), z = P.read<float>(false, "vertex");
        if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
          P.fail("triangle " + std::to_string(t) + " has a non-finite coordinate (binary, byte offset " +
                 std::to_string(P.offset() - 12) + ")");
        c[j] = M.vertex(x, y, z);
      }
      P.skip_bytes(2, "attribute");
      for (int j = 0; j < 3; ++j) M.S.F.push_back(c[j]);
    }
    if (n == 0) throw InputError(path + ": no triangles");
    return M.S.finish(path);
  }
  if (!solid) {
    if (size < 84) P.fail("not an STL file (too short for binary STL, does not start with 'solid')");
    P.fail("binary STL truncated: header says " + std::to_string(n) + " triangles (" +
           std::to_string((long long)expected) + " bytes), file has " + std::to_string(size) + " bytes");
  }
  // A NUL byte means binary data behind a header that happens to start with "solid" (some
  // writers put "solid" there): the size does not match the triangle count.
  if (size >= 84 && std::memchr(data.data(), 0, size) != nullptr)
    P.fail("binary STL (its header starts with 'solid') with a size that does not match: header says " +
           std::to_string(n) + " triangles (" + std::to_string((long long)expected) + " bytes), file has " +
           std::to_string(size) + " bytes");
  // ASCII
  if (Parser::has_utf8_bom(data)) P.skip_bytes(3, "byte-order mark");
  std::vector<int> poly;
  bool in_loop = false;
  int loop_line = 0;
  for (;;) {
    std::string_view tok = P.next_token();
    if (tok.empty()) break;
    if (iequals(tok, "solid") || iequals(tok, "endsolid")) {
      if (in_loop) P.fail("'" + std::string(tok) + "' inside a facet loop");
      P.rest_of_line();  // name
    } else if (iequals(tok, "facet")) {
      if (in_loop) P.fail("'facet' inside a facet loop");
      P.rest_of_line();  // normal nx ny nz (not needed)
    } else if (iequals(tok, "outer")) {
      if (in_loop) P.fail("nested 'outer loop'");
      if (!iequals(P.line_token(), "loop")) P.fail("expected 'outer loop'");
      in_loop = true;
      loop_line = P.line();
      poly.clear();
    } else if (iequals(tok, "vertex")) {
      if (!in_loop) P.fail("'vertex' outside 'outer loop'");
      double x = P.line_double("vertex x"), y = P.line_double("vertex y"), z = P.line_double("vertex z");
      poly.push_back(M.vertex(x, y, z));
    } else if (iequals(tok, "endloop")) {
      if (!in_loop) P.fail("'endloop' without 'outer loop'");
      if (poly.size() < 3)
        P.fail_at(loop_line, "facet with " + std::to_string(poly.size()) + " vertices (need at least 3)");
      M.S.add_polygon(poly);
      in_loop = false;
    } else if (iequals(tok, "endfacet")) {
      if (in_loop) P.fail("'endfacet' before 'endloop'");
    } else {
      P.fail("unexpected " + quote(tok) + " in ASCII STL");
    }
  }
  if (in_loop) P.fail("file ends inside a facet loop: truncated");
  if (M.S.F.empty()) throw InputError(path + ": no triangles");
  return M.S.finish(path);
}

void write_stl(const std::string& path, const TriMesh& m) {
  std::string s;
  s.reserve(84 + size_t(m.F.rows()) * 50);
  std::string header = "shapemap binary STL";
  header.resize(80, ' ');
  s += header;
  put_le<std::uint32_t>(s, std::uint32_t(m.F.rows()));
  Eigen::MatrixXd N = face_normals(m.V, m.F);
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    for (int j = 0; j < 3; ++j) put_le<float>(s, float(N(f, j)));
    for (int c = 0; c < 3; ++c)
      for (int j = 0; j < 3; ++j) put_le<float>(s, float(m.V(m.F(f, c), j)));
    put_le<std::uint16_t>(s, 0);
  }
  write_bytes_atomic(path, s);
}

}  // namespace shapemap::detail
