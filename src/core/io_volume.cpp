// Tetrahedral mesh readers and writers: Medit .mesh, legacy VTK (ASCII and binary),
// gmsh .msh (v2 and v4 ASCII), TetGen .node/.ele. See docs/formats.md.
#include "io_detail.h"
#include "shapemap/io.h"
#include <filesystem>

namespace shapemap::detail {

namespace {

struct VolumeBuilder {
  std::vector<double> V;
  std::vector<int> T;
  int num_vertices() const { return int(V.size() / 3); }
  TetMesh finish(const std::string& path) const {
    require_read(path, V, T, "tetrahedra");
    return {to_matrix(V, 3), to_matrix(T, 4)};
  }
};

bool starts_with_letter(std::string_view t) {
  return !t.empty() && ((t[0] >= 'a' && t[0] <= 'z') || (t[0] >= 'A' && t[0] <= 'Z'));
}

std::string index_range(long long i, int n, const char* what = "vertex", const char* whats = "vertices") {
  return std::string(what) + " index " + std::to_string(i) + " out of range (" + std::to_string(n) + " " + whats +
         ")";
}

}  // namespace

// ---------------------------------------------------------------------------------
// Medit .mesh (ASCII): keywords MeshVersionFormatted, Dimension 3, Vertices,
// Tetrahedra, End; other sections are skipped. Indices are 1-based.
TetMesh read_medit(const std::string& path) {
  TextFile file(path);
  Parser& P = file.P;
  VolumeBuilder B;
  std::vector<long long> raw;
  std::vector<int> raw_line;
  bool have_v = false, have_t = false, any = false;
  for (;;) {
    std::string_view kw = P.next_token();
    if (kw.empty()) break;
    if (!starts_with_letter(kw)) P.fail("expected a section keyword, found " + quote(kw));
    any = true;
    if (iequals(kw, "End")) break;
    if (iequals(kw, "MeshVersionFormatted")) {
      P.next_int("version");
    } else if (iequals(kw, "Dimension")) {
      long long d = P.next_int("dimension");
      if (d != 3) P.fail("dimension " + std::to_string(d) + " (need 3)");
    } else if (iequals(kw, "Vertices")) {
      if (have_v) P.fail("second Vertices section");
      have_v = true;
      int n = P.check_count(P.next_int("vertex count"), 8, "vertex");
      B.V.reserve(size_t(n) * 3);
      for (int i = 0; i < n; ++i) {
        double x = P.next_double("vertex x"), y = P.next_double("vertex y"), z = P.next_double("vertex z");
        P.next_int("vertex reference");
        B.V.insert(B.V.end(), {x, y, z});
      }
    } else if (iequals(kw, "Tetrahedra")) {
      if (have_t) P.fail("second Tetrahedra section");
      have_t = true;
      int m = P.check_count(P.next_int("tetrahedron count"), 10, "tetrahedron");
      raw.reserve(size_t(m) * 4);
      raw_line.reserve(size_t(m));
      for (int t = 0; t < m; ++t) {
        P.skip_space();
        raw_line.push_back(P.line());
        for (int j = 0; j < 4; ++j) raw.push_back(P.next_int("tetrahedron vertex"));
        P.next_int("tetrahedron reference");
      }
    } else {
      // Unknown or unused section (Triangles, Edges, Corners, ...): skip its numbers.
      while (!P.eof()) {
        std::string_view t = P.peek_token();
        if (t.empty() || starts_with_letter(t)) break;
        P.next_token();
      }
    }
  }
  if (!any) throw InputError(path + ": empty file");
  if (!have_v) throw InputError(path + ": no Vertices section");
  if (!have_t) throw InputError(path + ": no Tetrahedra section");
  const int n = B.num_vertices();
  B.T.resize(raw.size());
  for (size_t k = 0; k < raw.size(); ++k) {
    if (raw[k] < 1 || raw[k] > n) P.fail_at(raw_line[k / 4], index_range(raw[k], n) + " (1-based)");
    B.T[k] = int(raw[k] - 1);
  }
  return B.finish(path);
}

void write_medit(const std::string& path, const TetMesh& m) {
  std::string s;
  s.reserve(size_t(m.V.rows()) * 64 + size_t(m.T.rows()) * 40 + 100);
  s += "MeshVersionFormatted 2\nDimension 3\nVertices\n" + std::to_string(m.V.rows()) + "\n";
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    for (int j = 0; j < 3; ++j) {
      append_double(s, m.V(i, j));
      s += ' ';
    }
    s += "0\n";
  }
  s += "Tetrahedra\n" + std::to_string(m.T.rows()) + "\n";
  for (Eigen::Index t = 0; t < m.T.rows(); ++t) {
    for (int j = 0; j < 4; ++j) {
      append_int(s, m.T(t, j) + 1);
      s += ' ';
    }
    s += "0\n";
  }
  s += "End\n";
  write_bytes_atomic(path, s);
}

// ---------------------------------------------------------------------------------
// Legacy VTK unstructured grid, ASCII or BINARY (big endian); keywords in any case, as
// VTK's own reader accepts them. POINTS float|double,
// CELLS (classic "n size" list, or the 5.1 OFFSETS/CONNECTIVITY form), CELL_TYPES;
// cells of type 10 (VTK_TETRA) are kept, other cells ignored.
namespace {

// One legacy VTK file being read: the parser, the encoding and the three sections read.
struct VtkReader {
  Parser& P;
  const std::string& path;
  bool binary = false;
  std::vector<double> pts;
  std::vector<long long> cells, offsets, types;
  bool have_points = false, have_cells = false, have_types = false, new_cells = false;
  int num_cells = 0, points_line = 0, cells_line = 0, types_line = 0;

  VtkReader(Parser& parser, const std::string& p) : P(parser), path(p) {}

  // "# vtk ...", title, ASCII|BINARY, DATASET UNSTRUCTURED_GRID.
  void header() {
    std::string_view head = P.rest_of_line();
    if (head.size() < 6 || head[0] != '#' || head.find("vtk") == std::string_view::npos)
      P.fail_at(1, "not a legacy VTK file (first line " + quote(head) + ")");
    P.rest_of_line();  // title
    std::string_view enc = P.next_token();
    if (iequals(enc, "BINARY")) binary = true;
    else if (!iequals(enc, "ASCII")) P.fail("expected ASCII or BINARY, found " + quote(enc));
    if (!iequals(P.next_token(), "DATASET")) P.fail("expected DATASET");
    std::string_view ds = P.next_token();
    if (!iequals(ds, "UNSTRUCTURED_GRID"))
      P.fail("DATASET " + quote(ds) + " is not supported (need UNSTRUCTURED_GRID; surfaces: use .obj/.off/.ply/.stl)");
  }

  // Reads `count` integers of a binary type ("int", "vtktypeint64", ...) or ASCII.
  void read_ints(int count, std::string_view type, const std::string& what, std::vector<long long>& out) {
    out.clear();
    if (!binary) {
      P.check_count(count, 2, what);
      out.reserve(size_t(count));
      for (int i = 0; i < count; ++i) out.push_back(P.next_int(what));
      return;
    }
    bool i64 = type == "vtktypeint64" || type == "long" || type == "vtkIdType" || type == "long_long";
    bool i32 = type == "int" || type == "vtktypeint32" || type.empty();
    if (!i64 && !i32) P.fail("unsupported integer type " + quote(type) + " for " + what);
    P.check_count(count, i64 ? 8 : 4, what);
    out.reserve(size_t(count));
    for (int i = 0; i < count; ++i)
      out.push_back(i64 ? (long long)P.read<std::int64_t>(true, what) : (long long)P.read<std::int32_t>(true, what));
  }

  void points() {
    if (have_points) P.fail("second POINTS section");
    have_points = true;
    points_line = P.line();
    long long n_raw = P.next_int("point count");
    std::string_view type = P.next_token();
    bool dbl = iequals(type, "double"), flt = iequals(type, "float");
    if (!dbl && !flt) P.fail("POINTS type " + quote(type) + " is not supported (need float or double)");
    if (!binary) {
      int n = P.check_count(n_raw, 6, "point");
      pts.reserve(size_t(n) * 3);
      for (int i = 0; i < 3 * n; ++i) pts.push_back(P.next_double("point coordinate"));
      return;
    }
    P.rest_of_line();
    int n = P.check_count(n_raw, dbl ? 24 : 12, "point");
    pts.reserve(size_t(n) * 3);
    for (int i = 0; i < 3 * n; ++i) {
      double x = dbl ? P.read<double>(true, "POINTS") : double(P.read<float>(true, "POINTS"));
      if (!std::isfinite(x))
        P.fail_at(points_line, "point " + std::to_string(i / 3) + " has a non-finite coordinate (binary)");
      pts.push_back(x);
    }
  }

  // CELLS: the classic "n size" list, or VTK 5.1's OFFSETS / CONNECTIVITY.
  void cell_list() {
    if (have_cells) P.fail("second CELLS section");
    have_cells = true;
    cells_line = P.line();
    long long a = P.next_int("cell count"), b = P.next_int("cell list size");
    bool offsets_next;
    if (binary) {
      P.rest_of_line();
      offsets_next = P.remaining() >= 7 && std::memcmp(P.pos(), "OFFSETS", 7) == 0;
    } else {
      offsets_next = iequals(P.peek_token(), "OFFSETS");
    }
    if (!offsets_next) {
      num_cells = P.check_count(a, binary ? 4 : 2, "cell");
      read_ints(P.check_count(b, binary ? 4 : 2, "cell list"), "int", "CELLS", cells);
      return;
    }
    new_cells = true;  // CELLS <offsets> <connectivity size>
    P.next_token();
    std::string_view ot = P.next_token();
    if (binary) P.rest_of_line();
    read_ints(P.check_count(a, binary ? 4 : 2, "offset"), ot, "OFFSETS", offsets);
    if (!iequals(P.next_token(), "CONNECTIVITY")) P.fail("expected CONNECTIVITY after OFFSETS");
    std::string_view ct = P.next_token();
    if (binary) P.rest_of_line();
    read_ints(P.check_count(b, binary ? 4 : 2, "connectivity"), ct, "CONNECTIVITY", cells);
    num_cells = offsets.empty() ? 0 : int(offsets.size()) - 1;
  }

  void cell_types() {
    if (have_types) P.fail("second CELL_TYPES section");
    have_types = true;
    types_line = P.line();
    long long m = P.next_int("cell type count");
    if (binary) P.rest_of_line();
    read_ints(P.check_count(m, binary ? 4 : 2, "cell type"), "int", "CELL_TYPES", types);
  }

  // Sections up to POINTS, CELLS and CELL_TYPES; others skipped (ASCII) or refused (binary,
  // except METADATA).
  void sections() {
    for (;;) {
      std::string_view kw = P.next_token();
      if (kw.empty()) break;
      if (iequals(kw, "POINTS")) {
        points();
      } else if (iequals(kw, "CELLS")) {
        cell_list();
      } else if (iequals(kw, "CELL_TYPES")) {
        cell_types();
      } else if (have_points && have_cells && have_types) {
        break;  // POINT_DATA, CELL_DATA, FIELD...: not needed
      } else if (!binary) {
        // Skip an unneeded section (FIELD, METADATA, ...) up to the next one we read.
        while (!P.eof()) {
          std::string_view t = P.peek_token();
          if (t.empty() || iequals(t, "POINTS") || iequals(t, "CELLS") || iequals(t, "CELL_TYPES")) break;
          P.next_token();
        }
      } else if (iequals(kw, "METADATA")) {
        // Text lines up to an empty line.
        P.rest_of_line();
        while (!P.eof() && !P.rest_of_line().empty()) {
        }
      } else {
        P.fail("section " + quote(kw) + " before POINTS/CELLS/CELL_TYPES is not supported in binary VTK");
      }
    }
    if (!have_points) throw InputError(path + ": no POINTS section");
    if (!have_cells) throw InputError(path + ": no CELLS section");
    if (!have_types) throw InputError(path + ": no CELL_TYPES section");
    if (int(types.size()) != num_cells)
      P.fail_at(types_line, "CELL_TYPES lists " + std::to_string(types.size()) + " cells, CELLS lists " +
                                std::to_string(num_cells));
  }

  // The tets (cell type 10) of the cell list, checked.
  TetMesh tets() {
    VolumeBuilder B;
    B.V = std::move(pts);
    const int n = B.num_vertices();
    const long long size = (long long)cells.size();
    long long pos = 0;
    for (int c = 0; c < num_cells; ++c) {
      long long start, k;
      if (new_cells) {
        start = offsets[c];
        k = offsets[c + 1] - offsets[c];
        if (start < 0 || k < 0 || offsets[c + 1] > size)
          P.fail_at(cells_line, "cell " + std::to_string(c) + ": bad OFFSETS");
      } else {
        if (pos >= size) P.fail_at(cells_line, "CELLS list ends before cell " + std::to_string(c));
        k = cells[pos];
        start = pos + 1;
        if (k < 0 || k > size - start)
          P.fail_at(cells_line, "cell " + std::to_string(c) + " has a bad vertex count " + std::to_string(k));
        pos = start + k;
      }
      if (types[c] != 10) continue;
      if (k != 4) P.fail_at(cells_line, "tetrahedron cell " + std::to_string(c) + " has " + std::to_string(k) + " vertices");
      for (int j = 0; j < 4; ++j) {
        long long i = cells[start + j];
        if (i < 0 || i >= n) P.fail_at(cells_line, "cell " + std::to_string(c) + ": " + index_range(i, n, "point", "points"));
        B.T.push_back(int(i));
      }
    }
    if (!new_cells && pos != size)
      P.fail_at(cells_line, "CELLS size " + std::to_string(size) + " does not match its cells (" +
                                std::to_string(pos) + " values used)");
    if (B.T.empty()) throw InputError(path + ": no tetrahedra (VTK cell type 10)");
    return B.finish(path);
  }
};

}  // namespace

TetMesh read_vtk(const std::string& path) {
  std::string data = read_file_bytes(path);
  Parser P(path, data);
  VtkReader r(P, path);
  r.header();
  r.sections();
  return r.tets();
}

// ---------------------------------------------------------------------------------
// gmsh .msh: v2.x ASCII and v4.0/v4.1 ASCII; element type 4 (4-node tetrahedron).
namespace {

// One gmsh file being read: the format version, the nodes (tag -> row) and the tets.
struct GmshReader {
  Parser& P;
  int major = 0;
  bool v40 = false;
  VolumeBuilder B;
  IdMap ids;
  bool have_nodes = false, have_elems = false;

  explicit GmshReader(Parser& parser) : P(parser) {}

  // $MeshFormat: version 2.x or 4.x, ASCII.
  void mesh_format() {
    if (P.next_token() != "$MeshFormat") P.fail("not a gmsh file (expected $MeshFormat)");
    std::string_view ver = P.next_token();
    double version = P.to_double(ver, "format version");
    long long file_type = P.next_int("file type");
    P.next_int("data size");
    if (file_type != 0) P.fail("binary gmsh files are not supported; save as ASCII (gmsh -save_all -format msh2)");
    if (version >= 2 && version < 3) major = 2;
    else if (version >= 4 && version < 4.05) major = 4, v40 = true;
    else if (version >= 4.05 && version < 5) major = 4;
    else P.fail("gmsh format version " + std::string(ver) + " is not supported (2.x or 4.x)");
    if (P.next_token() != "$EndMeshFormat") P.fail("expected $EndMeshFormat");
  }

  int node(long long tag, long long elem) {
    int i = ids.find(tag);
    if (i < 0) P.fail("element " + std::to_string(elem) + ": node " + std::to_string(tag) + " is not in $Nodes");
    return i;
  }
  void end_section(const char* name) {
    std::string_view t = P.next_token();
    if (t != name) P.fail(std::string("expected ") + name + ", found " + (t.empty() ? "end of file" : quote(t)));
  }
  void read_node(long long tag) {
    double x = P.line_double("node x"), y = P.line_double("node y"), z = P.line_double("node z");
    B.V.insert(B.V.end(), {x, y, z});
    ids.add(tag, B.num_vertices() - 1);
    P.skip_line();  // parametric coordinates, if any
  }
  void read_tet(long long tag) {
    for (int j = 0; j < 4; ++j) B.T.push_back(node(P.line_int("element node"), tag));
  }

  void nodes() {
    if (have_nodes) P.fail("second $Nodes section");
    have_nodes = true;
    if (major == 2) {
      int n = P.check_count(P.next_int("node count"), 8, "node");
      B.V.reserve(size_t(n) * 3);
      for (int i = 0; i < n; ++i) read_node(P.next_int("node tag"));
    } else {
      node_blocks();
    }
    long long dup = 0;
    if (ids.finish(&dup)) P.fail("node tag " + std::to_string(dup) + " appears twice");
    end_section("$EndNodes");
  }
  // A version 4 section's header: the entity block count and the count of `what` (each at
  // least `min_bytes` long in the file); 4.1 adds the least and greatest tag.
  std::pair<int, int> blocks_header(const std::string& what, double min_bytes) {
    const int blocks = P.check_count(P.next_int("entity block count"), 8, what + " block");
    const int n = P.check_count(P.next_int(what + " count"), min_bytes, what);
    if (!v40) {
      P.next_int("min " + what + " tag");
      P.next_int("max " + what + " tag");
    }
    return {blocks, n};
  }
  // Version 4: entity blocks; 4.1 lists a block's tags before its coordinates.
  void node_blocks() {
    const auto [blocks, n] = blocks_header("node", 8);
    B.V.reserve(size_t(n) * 3);
    long long total = 0;
    std::vector<long long> tags;
    for (int b = 0; b < blocks; ++b) {
      P.next_int("entity");
      P.next_int("entity");
      P.next_int("parametric flag");
      int k = P.check_count(P.next_int("nodes in block"), 8, "node");
      total += k;
      if (total > n) P.fail("node blocks hold more nodes than the header's " + std::to_string(n));
      if (v40) {
        for (int i = 0; i < k; ++i) read_node(P.next_int("node tag"));
      } else {
        tags.clear();
        for (int i = 0; i < k; ++i) tags.push_back(P.next_int("node tag"));
        for (int i = 0; i < k; ++i) {
          P.skip_space();
          read_node(tags[size_t(i)]);
        }
      }
    }
  }

  void elements() {
    if (!have_nodes) P.fail("$Elements before $Nodes");
    if (have_elems) P.fail("second $Elements section");
    have_elems = true;
    if (major == 2) {
      int m = P.check_count(P.next_int("element count"), 8, "element");
      for (int e = 0; e < m; ++e) {
        long long tag = P.next_int("element tag");
        long long type = P.line_int("element type");
        if (type == 4) {
          long long ntags = P.line_int("tag count");
          if (ntags < 0 || double(ntags) > double(P.remaining())) P.fail("bad tag count " + std::to_string(ntags));
          for (long long j = 0; j < ntags; ++j) P.line_int("element tag value");
          read_tet(tag);
        }
        P.skip_line();
      }
    } else {
      element_blocks();
    }
    end_section("$EndElements");
  }
  void element_blocks() {
    const auto [blocks, m] = blocks_header("element", 4);
    long long total = 0;
    for (int b = 0; b < blocks; ++b) {
      P.next_int("entity");
      P.next_int("entity");
      long long type = P.next_int("element type");
      int k = P.check_count(P.next_int("elements in block"), 4, "element");
      total += k;
      if (total > m) P.fail("element blocks hold more elements than the header's " + std::to_string(m));
      P.skip_line();
      for (int e = 0; e < k; ++e) {
        P.skip_space();
        long long tag = P.line_int("element tag");
        if (type == 4) read_tet(tag);
        P.skip_line();
      }
    }
  }

  // Any other $Section up to its $EndSection.
  void skip_section(std::string_view sec) {
    std::string end = "$End" + std::string(sec.substr(1));
    for (;;) {
      std::string_view t = P.next_token();
      if (t.empty()) P.fail("section " + std::string(sec) + " is not closed by " + end);
      if (t == end) break;
    }
  }
};

}  // namespace

TetMesh read_gmsh(const std::string& path) {
  std::string data = read_file_bytes(path);
  Parser P(path, data);
  GmshReader r(P);
  r.mesh_format();
  for (;;) {
    std::string_view sec = P.next_token();
    if (sec.empty()) break;
    if (sec == "$Nodes")
      r.nodes();
    else if (sec == "$Elements")
      r.elements();
    else if (sec.size() > 1 && sec[0] == '$')
      r.skip_section(sec);
    else
      P.fail("expected a $Section, found " + quote(sec));
  }
  if (!r.have_nodes) throw InputError(path + ": no $Nodes section");
  if (r.B.T.empty()) throw InputError(path + ": no tetrahedra (gmsh element type 4)");
  return r.B.finish(path);
}

void write_gmsh(const std::string& path, const TetMesh& m) {
  std::string s;
  s.reserve(size_t(m.V.rows()) * 64 + size_t(m.T.rows()) * 50 + 200);
  s += "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n" + std::to_string(m.V.rows()) + "\n";
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    append_int(s, i + 1);
    append_row(s, m.V, i);
    s += '\n';
  }
  s += "$EndNodes\n$Elements\n" + std::to_string(m.T.rows()) + "\n";
  for (Eigen::Index t = 0; t < m.T.rows(); ++t) {
    append_int(s, t + 1);
    s += " 4 2 1 1";
    append_row(s, m.T, t, 1);
    s += '\n';
  }
  s += "$EndElements\n";
  write_bytes_atomic(path, s);
}

// ---------------------------------------------------------------------------------
// TetGen .node/.ele: either name given, the other is found by replacing the
// extension. Node numbers may start at 0 or 1 (any numbering is mapped).
namespace {
// The .node and .ele paths of a TetGen pair given either one: the given path as it is, its
// companion in the same letter case (a.node + a.ele, a.NODE + a.ELE, a.Node + a.Ele), or
// in another case if only that one exists.
std::pair<std::string, std::string> tetgen_paths(const std::string& path) {
  const size_t dot = path.rfind('.');
  const std::string stem = path.substr(0, dot), ext = path.substr(dot + 1);
  auto is_upper = [](char c) { return c >= 'A' && c <= 'Z'; };
  const bool all_upper = !ext.empty() && std::all_of(ext.begin(), ext.end(), is_upper);
  const bool capitalized = !ext.empty() && is_upper(ext[0]) && !all_upper;
  auto companion = [&](const std::string& lower) {
    std::string upper = lower, cap = lower;
    for (char& c : upper) c = char(c - 'a' + 'A');
    cap[0] = upper[0];
    const std::string order[3] = {all_upper ? upper : capitalized ? cap : lower, lower, upper};
    for (const std::string& e : order) {
      std::error_code ec;
      if (std::filesystem::exists(stem + "." + e, ec)) return stem + "." + e;
    }
    return stem + "." + order[0];
  };
  if (iequals(ext, "node")) return {path, companion("ele")};
  return {companion("node"), path};
}
}  // namespace

TetMesh read_tetgen(const std::string& path) {
  auto [node_path, ele_path] = tetgen_paths(path);
  VolumeBuilder B;
  IdMap ids;
  {
    TextFile file(node_path);
    Parser& P = file.P;
    if (!P.more()) P.fail("empty file");
    long long n_raw = P.line_int("point count");
    long long dim = P.line_int("dimension");
    if (dim != 3) P.fail("dimension " + std::to_string(dim) + " (need 3)");
    P.skip_line();
    int n = P.check_count(n_raw, 8, "point");
    B.V.reserve(size_t(n) * 3);
    for (int i = 0; i < n; ++i) {
      P.skip_space();
      long long id = P.line_int("point number");
      double x = P.line_double("point x"), y = P.line_double("point y"), z = P.line_double("point z");
      B.V.insert(B.V.end(), {x, y, z});
      ids.add(id, i);
      P.skip_line();
    }
    long long dup = 0;
    if (ids.finish(&dup)) P.fail("point number " + std::to_string(dup) + " appears twice");
  }
  {
    TextFile file(ele_path);
    Parser& P = file.P;
    if (!P.more()) P.fail("empty file");
    long long m_raw = P.line_int("tetrahedron count");
    long long npt = P.line_int("nodes per tetrahedron");
    if (npt != 4 && npt != 10) P.fail("nodes per tetrahedron " + std::to_string(npt) + " (need 4 or 10)");
    P.skip_line();
    int m = P.check_count(m_raw, 10, "tetrahedron");
    B.T.reserve(size_t(m) * 4);
    for (int t = 0; t < m; ++t) {
      P.skip_space();
      long long id = P.line_int("tetrahedron number");
      for (int j = 0; j < int(npt); ++j) {  // 10 nodes: the 6 edge midpoints follow (not used)
        long long v = P.line_int("tetrahedron node");
        int i = ids.find(v);
        if (i < 0)
          P.fail("tetrahedron " + std::to_string(id) + ": node " + std::to_string(v) + " is not in " + node_path);
        if (j < 4) B.T.push_back(i);
      }
      P.skip_line();
    }
    if (m == 0) throw InputError(ele_path + ": no tetrahedra");
  }
  return B.finish(node_path);
}

void write_tetgen(const std::string& path, const TetMesh& m) {
  auto [node_path, ele_path] = tetgen_paths(path);
  std::string s;
  s.reserve(size_t(m.V.rows()) * 64 + 100);
  s += std::to_string(m.V.rows()) + " 3 0 0\n";
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    append_int(s, i + 1);
    append_row(s, m.V, i);
    s += '\n';
  }
  s += "# written by shapemap\n";
  std::string e;
  e.reserve(size_t(m.T.rows()) * 40 + 100);
  e += std::to_string(m.T.rows()) + " 4 0\n";
  for (Eigen::Index t = 0; t < m.T.rows(); ++t) {
    append_int(e, t + 1);
    append_row(e, m.T, t, 1);
    e += '\n';
  }
  e += "# written by shapemap\n";
  // Both files or neither: a folder in the way is found before anything is written, and
  // a failure of the second write removes the first.
  for (const std::string& q : {node_path, ele_path})
    if (std::filesystem::is_directory(q)) throw InputError(q + ": is a folder; nothing was written");
  write_bytes_atomic(node_path, s);
  try {
    write_bytes_atomic(ele_path, e);
  } catch (...) {
    std::error_code ec;
    std::filesystem::remove(node_path, ec);
    throw;
  }
}

}  // namespace shapemap::detail
