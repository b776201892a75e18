// Readers and writers of every format: round trips, small hand-written files of each
// variant (incl. binary PLY big endian and binary VTK), and exact error messages.
#include "io_test_util.h"
#include "shapemap/error.h"
#include "shapemap/io.h"
#include "shapemap/maps.h"
#include <gtest/gtest.h>
#include <algorithm>
#include <cstdint>
#include <cstring>

using namespace shapemap;
using namespace shapemap::testing;

namespace {

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

void expect_same(const TriMesh& a, const TriMesh& b) {
  ASSERT_EQ(a.V.rows(), b.V.rows());
  ASSERT_EQ(a.F.rows(), b.F.rows());
  EXPECT_TRUE(a.V == b.V);
  EXPECT_TRUE(a.F == b.F);
}
void expect_same(const TetMesh& a, const TetMesh& b) {
  ASSERT_EQ(a.V.rows(), b.V.rows());
  ASSERT_EQ(a.T.rows(), b.T.rows());
  EXPECT_TRUE(a.V == b.V);
  EXPECT_TRUE(a.T == b.T);
}

// The tetrahedron 0,1,2,3 surface, outward.
const char* kTetObjFaces = "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

}  // namespace

TEST(IO, SurfaceRoundTripEveryFormat) {
  TriMesh m = octahedron();
  m.V(0, 1) = 1.0 / 3.0;  // a value that needs all 17 digits
  for (const char* ext : {".obj", ".off", ".ply"}) {
    std::string p = scratch(std::string("rt") + ext);
    write_surface(p, m);
    expect_same(read_surface(p), m);
  }
  // STL stores floats and no vertex numbering: use float-exact coordinates and
  // vertices numbered in order of first appearance in F.
  TriMesh s = octahedron(1.25);
  std::vector<int> order, seen(6, -1);
  for (int f = 0; f < s.F.rows(); ++f)
    for (int j = 0; j < 3; ++j)
      if (seen[s.F(f, j)] < 0) {
        seen[s.F(f, j)] = int(order.size());
        order.push_back(s.F(f, j));
      }
  TriMesh s2 = s;
  for (int i = 0; i < 6; ++i) s2.V.row(i) = s.V.row(order[i]);
  for (int f = 0; f < s.F.rows(); ++f)
    for (int j = 0; j < 3; ++j) s2.F(f, j) = seen[s.F(f, j)];
  std::string p = scratch("rt.stl");
  write_surface(p, s2);
  EXPECT_EQ(read_bytes(p).size(), 84u + 50u * 8u);
  expect_same(read_surface(p), s2);
}

TEST(IO, VolumeRoundTripEveryFormat) {
  TetMesh m = grid_tets();
  m.V(5, 2) = 1.0 / 7.0;
  for (const char* ext : {".vtk", ".mesh", ".msh", ".node", ".ele"}) {
    std::string p = scratch(std::string("vrt") + ext);
    write_volume(p, m);
    expect_same(read_volume(p), m);
  }
  // Both TetGen files exist whichever name was given.
  EXPECT_TRUE(std::filesystem::exists(scratch("vrt.node")));
  EXPECT_TRUE(std::filesystem::exists(scratch("vrt.ele")));
}

TEST(IO, VtkWithPointAndCellData) {
  TetMesh m = cube_tets();
  Eigen::VectorXd pd = Eigen::VectorXd::LinSpaced(8, 0, 1), cd = Eigen::VectorXd::Constant(6, 2.5);
  std::string p = scratch("data.vtk");
  write_vtk(p, m, {{"distortion", pd}}, {{"cell value", cd}});
  std::string text = read_bytes(p);
  EXPECT_NE(text.find("POINT_DATA 8\nSCALARS distortion double 1\nLOOKUP_TABLE default\n"), std::string::npos);
  EXPECT_NE(text.find("CELL_DATA 6\nSCALARS cell_value double 1"), std::string::npos);
  expect_same(read_volume(p), m);
  EXPECT_THROW(write_vtk(p, m, {{"short", Eigen::VectorXd::Zero(3)}}), Error);
}

TEST(IO, AtomicWriteLeavesNoTemporary) {
  std::string dir = scratch("atomic");
  std::filesystem::create_directories(dir);
  write_text_atomic(dir + "/a.txt", "hello\n");
  write_text_atomic(dir + "/a.txt", "again\n");
  EXPECT_EQ(read_bytes(dir + "/a.txt"), "again\n");
  int files = 0;
  for (auto& e : std::filesystem::directory_iterator(dir)) ++files, (void)e;
  EXPECT_EQ(files, 1);
  EXPECT_THROW(write_text_atomic(dir + "/no/such/folder/a.txt", "x"), InputError);
}

TEST(IO, ObjVariants) {
  std::string p = scratch("variants.obj");
  write_file(p,
             "# comment\nmtllib x.mtl\no thing\n"
             "v 0 0 0\nv 1 0 0\nv 1 1 0 1.0\nv 0 1 0 0.5 0.5 0.5\nv 0.5 0.5 1e0\n"
             "vt 0 0\nvt 1 0\nvn 0 0 1\n"
             "g group\nusemtl m\ns off\n"
             "f 1/1/1 2/2/1 3//1 4\n"  // quad: fan-triangulated
             "f -5 -4 -1\n"            // negative: 1 2 5
             "f 2/1 3/1 5/1   \r\n"
             "l 1 2\n");
  TriMesh m = read_surface(p);
  ASSERT_EQ(m.V.rows(), 5);
  ASSERT_EQ(m.F.rows(), 4);
  Eigen::MatrixXi F(4, 3);
  F << 0, 1, 2, 0, 2, 3, 0, 1, 4, 1, 2, 4;
  EXPECT_TRUE(m.F == F);
  EXPECT_EQ(m.V(4, 2), 1.0);
}

TEST(IO, ObjErrorsNameFileAndLine) {
  std::string p = scratch("bunny.obj");
  std::string s;
  for (int i = 0; i < 8; ++i) s += "v " + std::to_string(i) + " 0 0\n";
  for (int i = 0; i < 8; ++i) s += "f 1 2 3\n";
  s += "f 1 2 9\n";  // line 17
  write_file(p, s);
  EXPECT_EQ(error_of([&] { read_surface(p); }), p + ":17: face index 9 out of range (8 vertices)");
  write_file(p, "v 0 0 0\nv 1 nan 0\n");
  EXPECT_EQ(error_of([&] { read_surface(p); }), p + ":2: vertex y is not finite ('nan')");
  write_file(p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n");
  EXPECT_EQ(error_of([&] { read_surface(p); }), p + ":4: face index 0 (OBJ indices start at 1)");
  write_file(p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 -4 2\n");
  EXPECT_EQ(error_of([&] { read_surface(p); }), p + ":4: face index -4 out of range (3 vertices)");
  // A damaged keyword (a byte of the space after "f" flipped) is an error, not a skipped line.
  write_file(p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf\xc2" "1 2 3\n");
  EXPECT_EQ(error_of([&] { read_surface(p); }), p + ":4: not an OBJ statement: line starts with 'f\\xc21'");
  write_file(p, "");
  EXPECT_EQ(error_of([&] { read_surface(p); }), p + ": no vertices");
  write_file(p, "v 0 0 0\n");
  EXPECT_EQ(error_of([&] { read_surface(p); }), p + ": no faces");
  EXPECT_EQ(error_of([&] { read_surface(scratch("missing.obj")); }), scratch("missing.obj") + ": cannot open (no such file)");
  EXPECT_EQ(error_of([&] { read_surface(scratch("x.abc")); }),
            scratch("x.abc") + ": unknown surface format '.abc' (use .obj .off .ply .stl)");
}

TEST(IO, OffVariants) {
  std::string p = scratch("variants.off");
  write_file(p,
             "COFF 5 2 0 # counts on the header line\n"
             "# a comment line\n\n"
             "0 0 0 255 0 0 255\n1 0 0 255 0 0 255\n1 1 0 0 0 0 0\n0 1 0 0 0 0 0\n0.5 0.5 1 0 0 0 0\n"
             "4 0 1 2 3 10 20 30\n"
             "3 1 2 4\n");
  TriMesh m = read_surface(p);
  ASSERT_EQ(m.V.rows(), 5);
  ASSERT_EQ(m.F.rows(), 3);
  Eigen::MatrixXi F(3, 3);
  F << 0, 1, 2, 0, 2, 3, 1, 2, 4;
  EXPECT_TRUE(m.F == F);
  write_file(p, "4 4 6\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n");  // no header
  EXPECT_EQ(read_surface(p).F.rows(), 4);
  write_file(p, "OFF\n1000000000000 1 0\n0 0 0\n");
  EXPECT_EQ(error_of([&] { read_surface(p); }), p + ":2: vertex count 1000000000000 is too large");
  write_file(p, "OFF\n100000 1 0\n0 0 0\n");
  EXPECT_NE(error_of([&] { read_surface(p); }).find(p + ":2: vertex count 100000 does not fit"), std::string::npos);
  write_file(p, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n");
  EXPECT_EQ(error_of([&] { read_surface(p); }), p + ":6: face index 3 out of range (3 vertices)");
  write_file(p, "4OFF\n3 1 0\n");
  EXPECT_NE(error_of([&] { read_surface(p); }).find("not supported"), std::string::npos);
}

TEST(IO, PlyAsciiWithExtraElementsAndProperties) {
  std::string p = scratch("ascii.ply");
  write_file(p,
             "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\nobj_info x\r\n"
             "element vertex 4\r\nproperty float x\r\nproperty float y\r\nproperty float z\r\n"
             "property float nx\r\nproperty uchar red\r\nproperty list uchar float texcoord\r\n"
             "element face 2\r\nproperty uchar flags\r\nproperty list uint int vertex_index\r\n"
             "element edge 1\r\nproperty int vertex1\r\nproperty int vertex2\r\n"
             "end_header\r\n"
             "0 0 0 nan 255 2 0.5 0.5\r\n1 0 0 0 255 0\r\n1 1 0 0 255 0\r\n0 1 0 0 255 1 7\r\n"
             "9 4 0 1 2 3\r\n0 3 0 2 1\r\n"
             "0 1\r\n");
  TriMesh m = read_surface(p);
  ASSERT_EQ(m.V.rows(), 4);
  ASSERT_EQ(m.F.rows(), 3);
  Eigen::MatrixXi F(3, 3);
  F << 0, 1, 2, 0, 2, 3, 0, 2, 1;
  EXPECT_TRUE(m.F == F);
  EXPECT_EQ(m.V(2, 1), 1.0);
}

TEST(IO, PlyBinaryBigEndian) {
  std::string s =
      "ply\nformat binary_big_endian 1.0\n"
      "element vertex 4\nproperty double z\nproperty float x\nproperty float y\nproperty short extra\n"
      "element material 2\nproperty list ushort uchar name\nproperty int id\n"
      "element face 4\nproperty list uchar uint vertex_indices\n"
      "end_header\n";
  const float xy[4][2] = {{0, 0}, {1, 0}, {0, 1}, {0, 0}};
  const double z[4] = {0, 0, 0, 1.5};
  for (int i = 0; i < 4; ++i) {
    put<double>(s, z[i], true);
    put<float>(s, xy[i][0], true);
    put<float>(s, xy[i][1], true);
    put<std::int16_t>(s, -7, true);
  }
  for (int k = 0; k < 2; ++k) {  // the unknown element, skipped
    put<std::uint16_t>(s, 3, true);
    s += "abc";
    put<std::int32_t>(s, k, true);
  }
  const std::uint32_t F[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  for (auto& f : F) {
    put<std::uint8_t>(s, 3, true);
    for (auto v : f) put<std::uint32_t>(s, v, true);
  }
  std::string p = scratch("be.ply");
  write_file(p, s);
  TriMesh m = read_surface(p);
  ASSERT_EQ(m.V.rows(), 4);
  ASSERT_EQ(m.F.rows(), 4);
  EXPECT_EQ(m.V(3, 2), 1.5);
  EXPECT_EQ(m.V(1, 0), 1.0);
  EXPECT_EQ(m.F(3, 2), 3);
  EXPECT_NEAR(enclosed_volume(m.V, m.F), 1.5 / 6, 1e-15);
  // Truncated: the last index is cut.
  write_file(p, s.substr(0, s.size() - 2));
  EXPECT_NE(error_of([&] { read_surface(p); }).find("truncated"), std::string::npos);
  // A garbled count claiming 4e9 faces must not allocate.
  std::string g = s;
  g.replace(g.find("face 4"), 6, "face 4000000000");
  write_file(p, g);
  EXPECT_NE(error_of([&] { read_surface(p); }).find("is too large"), std::string::npos);
}

TEST(IO, PlyBinaryLittleEndianSmallTypes) {
  std::string s =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float32 x\nproperty float32 y\n"
      "property float32 z\nelement face 1\nproperty list uint8 uint16 vertex_indices\nend_header\n";
  for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) put<float>(s, v, false);
  put<std::uint8_t>(s, 3, false);
  for (std::uint16_t v : {0, 1, 2}) put<std::uint16_t>(s, v, false);
  std::string p = scratch("le.ply");
  write_file(p, s);
  TriMesh m = read_surface(p);
  EXPECT_EQ(m.F.rows(), 1);
  s[s.size() - 2] = 5;  // index 5 of 3
  write_file(p, s);
  EXPECT_NE(error_of([&] { read_surface(p); }).find("face index 5 out of range (3 vertices)"), std::string::npos);
}

TEST(IO, StlAsciiAndBinaryMergeVertices) {
  std::string p = scratch("a.stl");
  write_file(p,
             "solid thing\n"
             " facet normal 0 0 -1\n  outer loop\n   vertex 0 0 0\n   vertex 0 1 0\n   vertex 1 0 0\n  endloop\n endfacet\n"
             " facet normal 0 -1 0\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n   vertex 0 0 1\n  endloop\n endfacet\n"
             " FACET NORMAL -1 0 0\n  OUTER LOOP\n   VERTEX -0 0 0\n   VERTEX 0 0 1\n   VERTEX 0 1 0\n  ENDLOOP\n ENDFACET\n"
             " facet normal 1 1 1\n  outer loop\n   vertex 1 0 0\n   vertex 0 1 0\n   vertex 0 0 1\n  endloop\n endfacet\n"
             "endsolid thing\n");
  TriMesh m = read_surface(p);
  EXPECT_EQ(m.V.rows(), 4);  // -0 and 0 merged
  EXPECT_EQ(m.F.rows(), 4);
  EXPECT_NEAR(enclosed_volume(m.V, m.F), 1.0 / 6, 1e-15);
  // Binary whose header starts with "solid" (common): recognized by its size.
  std::string b = "solid but actually binary";
  b.resize(80, ' ');
  put<std::uint32_t>(b, 2, false);
  const float tri[2][3][3] = {{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{1, 0, 0}, {1, 1, 0}, {0, 1, 0}}};
  for (auto& t : tri) {
    for (int j = 0; j < 3; ++j) put<float>(b, 0, false);
    for (auto& v : t)
      for (float x : v) put<float>(b, x, false);
    put<std::uint16_t>(b, 0, false);
  }
  write_file(p, b);
  TriMesh q = read_surface(p);
  EXPECT_EQ(q.V.rows(), 4);
  EXPECT_EQ(q.F.rows(), 2);
  write_file(p, b.substr(0, b.size() - 10));
  EXPECT_NE(error_of([&] { read_surface(p); }).find("binary STL (its header starts with 'solid') with a size that "
                                                     "does not match: header says 2 triangles (184 bytes), file has 174"),
            std::string::npos)
      << error_of([&] { read_surface(p); });
  std::string c = b;
  c.replace(0, 5, "xxxxx");
  write_file(p, c.substr(0, c.size() - 10));
  EXPECT_NE(error_of([&] { read_surface(p); }).find("binary STL truncated: header says 2 triangles"), std::string::npos);
}

TEST(IO, VtkAsciiMixedCellsAndOrientation) {
  std::string p = scratch("mixed.vtk");
  // Tets listed with negative orientation (all): read back flipped to positive.
  write_file(p,
             "# vtk DataFile Version 2.0\nhand made\nASCII\n\nDATASET UNSTRUCTURED_GRID\n"
             "FIELD FieldData 1\nTIME 1 1 double\n0.5\n"
             "POINTS 5 float\n0 0 0 1 0 0 0 1 0\n0 0 1 0 0 -1\n"
             "CELLS 4 16\n3 0 1 2\n4 0 2 1 3\n1 4\n4 0 1 2 4\n"
             "CELL_TYPES 4\n5\n10\n1\n10\n"
             "CELL_DATA 4\nSCALARS a int 1\nLOOKUP_TABLE default\n1 2 3 4\n");
  TetMesh m = read_volume(p);
  ASSERT_EQ(m.V.rows(), 5);
  ASSERT_EQ(m.T.rows(), 2);
  Eigen::VectorXd vol = tet_volumes(m.V, m.T);
  EXPECT_GT(vol.minCoeff(), 0);
  write_file(p,
             "# vtk DataFile Version 3.0\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 double\n"
             "0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 4\nCELL_TYPES 1\n10\n");
  EXPECT_EQ(error_of([&] { read_volume(p); }), p + ":7: cell 0: point index 4 out of range (4 points)");
}

TEST(IO, VtkVersion51OffsetsConnectivity) {
  std::string p = scratch("v51.vtk");
  write_file(p,
             "# vtk DataFile Version 5.1\nvtk output\nASCII\nDATASET UNSTRUCTURED_GRID\n"
             "POINTS 5 float\n0 0 0 1 0 0 0 1 0\n0 0 1 0 0 -1\n\nMETADATA\nINFORMATION 0\n\n"
             "CELLS 3 7\nOFFSETS vtktypeint64\n0 4 7\nCONNECTIVITY vtktypeint64\n0 1 2 3 0 1 2\n"
             "CELL_TYPES 2\n10\n5\n");
  TetMesh m = read_volume(p);
  EXPECT_EQ(m.T.rows(), 1);
  EXPECT_EQ(m.V.rows(), 5);
}

TEST(IO, VtkBinaryBigEndian) {
  auto make = [](bool dbl) {
    std::string s = "# vtk DataFile Version 3.0\nbinary test\nBINARY\nDATASET UNSTRUCTURED_GRID\n";
    s += std::string("POINTS 5 ") + (dbl ? "double" : "float") + "\n";
    const double P[5][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
    for (auto& r : P)
      for (double x : r) dbl ? put<double>(s, x, true) : put<float>(s, float(x), true);
    s += "\nCELLS 3 13\n";
    for (int v : {4, 0, 1, 2, 3, 2, 3, 4, 4, 1, 2, 3, 4}) put<std::int32_t>(s, v, true);
    s += "\nCELL_TYPES 3\n";
    for (int v : {10, 3, 10}) put<std::int32_t>(s, v, true);
    s += "\nPOINT_DATA 5\nSCALARS d float 1\nLOOKUP_TABLE default\n";
    for (int i = 0; i < 5; ++i) put<float>(s, 1.0f, true);
    return s;
  };
  std::string p = scratch("bin.vtk");
  for (bool dbl : {false, true}) {
    std::string s = make(dbl);
    write_file(p, s);
    TetMesh m = read_volume(p);
    ASSERT_EQ(m.V.rows(), 5);
    ASSERT_EQ(m.T.rows(), 2);
    EXPECT_EQ(m.V(4, 2), 1.0);
    EXPECT_GT(tet_volumes(m.V, m.T).minCoeff(), 0);
    size_t cut = s.find("CELL_TYPES") + 15;
    write_file(p, s.substr(0, cut));
    EXPECT_NE(error_of([&] { read_volume(p); }).find("truncated"), std::string::npos);
    write_file(p, s.substr(0, s.find("CELLS") + 20));
    EXPECT_NE(error_of([&] { read_volume(p); }).find("truncated"), std::string::npos);
  }
}

TEST(IO, MeditWithOtherSections) {
  std::string p = scratch("hand.mesh");
  write_file(p,
             "MeshVersionFormatted 1\n# comment\nDimension\n3\n"
             "Vertices\n5\n0 0 0 1\n1 0 0 1\n0 1 0 1\n0 0 1 1\n1 1 1 0\n"
             "Corners\n2\n1 2\n"
             "Triangles\n1\n1 2 3 7\n"
             "Tetrahedra\n2\n1 2 3 4 0\n2 3 4 5 0\n"
             "Edges 1 1 2 0\n"
             "End\n");
  TetMesh m = read_volume(p);
  ASSERT_EQ(m.V.rows(), 5);
  ASSERT_EQ(m.T.rows(), 2);
  EXPECT_EQ(m.T(0, 0), 0);
  write_file(p, "MeshVersionFormatted 1\nDimension 3\nVertices\n4\n0 0 0 1\n1 0 0 1\n0 1 0 1\n0 0 1 1\n"
                "Tetrahedra\n1\n1 2 3 5 0\nEnd\n");
  EXPECT_EQ(error_of([&] { read_volume(p); }), p + ":11: vertex index 5 out of range (4 vertices) (1-based)");
  write_file(p, "MeshVersionFormatted 1\nDimension 2\n");
  EXPECT_EQ(error_of([&] { read_volume(p); }), p + ":2: dimension 2 (need 3)");
}

TEST(IO, GmshV2V40V41) {
  std::string p = scratch("hand.msh");
  write_file(p,
             "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n"
             "$PhysicalNames\n1\n3 1 \"the volume\"\n$EndPhysicalNames\n"
             "$Nodes\n5\n10 0 0 0\n20 1 0 0\n30 0 1 0\n40 0 0 1\n50 1 1 1\n$EndNodes\n"
             "$Elements\n3\n1 15 2 0 1 10\n2 2 2 0 1 10 20 30\n3 4 3 1 1 0 10 20 30 40\n$EndElements\n");
  TetMesh m = read_volume(p);
  ASSERT_EQ(m.V.rows(), 5);
  ASSERT_EQ(m.T.rows(), 1);
  Eigen::RowVector4i t = m.T.row(0);
  EXPECT_EQ(t.minCoeff(), 0);
  EXPECT_EQ(t.maxCoeff(), 3);
  // v4.1 with entities, parametric nodes, several blocks.
  write_file(p,
             "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
             "$Entities\n1 0 0 1\n1 0 0 0 0\n1 0 0 0 1 1 1 0 0\n$EndEntities\n"
             "$Nodes\n2 5 1 5\n0 1 0 1\n1\n0 0 0\n3 1 0 4\n2\n3\n4\n5\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n$EndNodes\n"
             "$Elements\n2 3 1 3\n0 1 15 1\n1 1\n3 1 4 2\n2 1 2 3 4\n3 2 3 4 5\n$EndElements\n");
  m = read_volume(p);
  ASSERT_EQ(m.V.rows(), 5);
  ASSERT_EQ(m.T.rows(), 2);
  EXPECT_EQ(m.V(4, 0), 1.0);
  // v4.0
  write_file(p,
             "$MeshFormat\n4 0 8\n$EndMeshFormat\n"
             "$Nodes\n1 4\n1 3 0 4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n"
             "$Elements\n1 1\n1 3 4 1\n1 1 2 3 4\n$EndElements\n");
  m = read_volume(p);
  EXPECT_EQ(m.T.rows(), 1);
  write_file(p, "$MeshFormat\n2.2 1 8\n$EndMeshFormat\n");
  EXPECT_NE(error_of([&] { read_volume(p); }).find("binary gmsh files are not supported"), std::string::npos);
  write_file(p,
             "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n1\n1 0 0 0\n$EndNodes\n"
             "$Elements\n1\n1 4 0 1 1 1 7\n$EndElements\n");
  EXPECT_EQ(error_of([&] { read_volume(p); }), p + ":10: element 1: node 7 is not in $Nodes");
}

TEST(IO, TetgenZeroAndOneBased) {
  std::string node = scratch("tg.node"), ele = scratch("tg.ele");
  write_file(node, "# points\n5 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n4 1 1 1 # last\n");
  write_file(ele, "2 4 0\n0 0 1 2 3\n1 1 2 4 3\n");
  TetMesh m = read_volume(ele);  // the .ele name works too
  ASSERT_EQ(m.T.rows(), 2);
  EXPECT_EQ(m.T(0, 0), 0);
  write_file(node, "5 3 1 1\n1 0 0 0 9 1\n2 1 0 0 9 1\n3 0 1 0 9 1\n4 0 0 1 9 1\n5 1 1 1 9 0\n");
  write_file(ele, "2 10 1\n1 1 2 3 4 5 5 5 5 5 5 7\n2 2 3 4 5 1 1 1 1 1 1 7\n");
  m = read_volume(node);
  ASSERT_EQ(m.T.rows(), 2);
  EXPECT_EQ(m.T(0, 0), 0);
  EXPECT_GT(tet_volumes(m.V, m.T).minCoeff(), 0);
  write_file(ele, "1 4 0\n1 1 2 3 9\n");
  EXPECT_EQ(error_of([&] { read_volume(node); }), ele + ":2: tetrahedron 1: node 9 is not in " + node);
  std::filesystem::remove(ele);
  EXPECT_EQ(error_of([&] { read_volume(node); }), ele + ": cannot open (no such file)");
}

TEST(IO, Landmarks) {
  TriMesh m = octahedron();
  std::string p = scratch("lm.txt");
  write_file(p, "# nose, tail\n3\n  5 # with comment\n\n1.0 0.1 -0.05\n");
  std::vector<int> l = read_landmarks(p, m.V);
  ASSERT_EQ(l.size(), 3u);
  EXPECT_EQ(l[0], 3);
  EXPECT_EQ(l[1], 5);
  EXPECT_EQ(l[2], 0);  // snapped to (1.1, 0, 0)
  EXPECT_EQ(read_landmarks(p, m.V, {1, 2})[2], 2);  // among candidates only
  write_file(p, "3\n6\n");
  EXPECT_EQ(error_of([&] { read_landmarks(p, m.V); }), p + ":2: landmark vertex 6 out of range (6 vertices)");
  write_file(p, "1 2\n");
  EXPECT_NE(error_of([&] { read_landmarks(p, m.V); }).find(p + ":1: expected a vertex index or 'x y z'"), std::string::npos);
  write_file(p, "# nothing\n");
  EXPECT_EQ(error_of([&] { read_landmarks(p, m.V); }), p + ": no landmarks");
}

// Real landmark files repeat points (the symmetric-volume-maps authors' files repeat one
// position three times): a repeated pair is kept once; a vertex with two different
// partners keeps both pairs; both are said in notes; unequal counts are an error.
TEST(IO, RepeatedLandmarksAreTidiedNotRefused) {
  TriMesh m = octahedron();
  const std::string p = scratch("lm_rep.txt");
  write_file(p, "3\n5\n3\n1.0 0.1 -0.05\n0\n");  // 3 twice, the point snaps to 0 (twice then)
  std::vector<int> la = read_landmarks(p, m.V);
  EXPECT_EQ(la, (std::vector<int>{3, 5, 3, 0, 0}));
  std::vector<int> lb = {1, 2, 1, 4, 4};  // pairs 1 = 3 and 4 = 5 repeat exactly
  std::vector<std::string> notes = tidy_landmark_pairs(la, lb, "a.txt", "b.txt");
  EXPECT_EQ(la, (std::vector<int>{3, 5, 0}));
  EXPECT_EQ(lb, (std::vector<int>{1, 2, 4}));
  ASSERT_EQ(notes.size(), 2u);
  EXPECT_NE(notes[0].find("landmark pair 3 (vertices 3, 1) repeats pair 1: kept once"), std::string::npos);
  EXPECT_NE(notes[1].find("landmark pair 5"), std::string::npos);
  // A vertex with two partners: both pairs stay.
  la = {3, 3, 5};
  lb = {1, 2, 4};
  notes = tidy_landmark_pairs(la, lb, "a.txt", "b.txt");
  EXPECT_EQ(la.size(), 3u);
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("a.txt: note: vertex 3 has 2 different partners: all kept"), std::string::npos);
  la = {1, 2};
  lb = {1};
  EXPECT_EQ(error_of([&] { tidy_landmark_pairs(la, lb, "a.txt", "b.txt"); }), "b.txt: 1 landmarks, but a.txt has 2");
}

TEST(IO, PathKinds) {
  EXPECT_TRUE(is_volume_path("a/b.VTK"));
  EXPECT_TRUE(is_volume_path("x.ele"));
  EXPECT_FALSE(is_volume_path("x.obj"));
  EXPECT_TRUE(is_surface_path("x.Ply"));
  EXPECT_FALSE(is_surface_path("x.mesh"));
  EXPECT_FALSE(is_surface_path("noext"));
}

// Text files saved with a UTF-8 byte-order mark (EF BB BF) read like the same files
// without it, in every text format; a binary STL keeps its header bytes as they are.
TEST(IO, Utf8ByteOrderMarkIsSkipped) {
  const std::string bom = "\xEF\xBB\xBF";
  TriMesh s = octahedron();
  for (const char* ext : {".obj", ".off", ".ply"}) {
    const std::string p = scratch(std::string("bom_plain") + ext), q = scratch(std::string("bom") + ext);
    write_surface(p, s);
    write_file(q, bom + read_bytes(p));
    expect_same(read_surface(q), s);
  }
  // ASCII STL: with the mark it must still be recognised as ASCII ("solid" after it).
  write_file(scratch("bom.stl"), bom + "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                                        "vertex 0 1 0\nendloop\nendfacet\nendsolid x\n");
  EXPECT_EQ(read_surface(scratch("bom.stl")).F.rows(), 1);
  TetMesh m = grid_tets();
  for (const char* ext : {".vtk", ".mesh", ".msh"}) {
    const std::string p = scratch(std::string("bomv_plain") + ext), q = scratch(std::string("bomv") + ext);
    write_volume(p, m);
    write_file(q, bom + read_bytes(p));
    expect_same(read_volume(q), m);
  }
  write_volume(scratch("bomtg.node"), m);
  write_file(scratch("bomtg.node"), bom + read_bytes(scratch("bomtg.node")));
  write_file(scratch("bomtg.ele"), bom + read_bytes(scratch("bomtg.ele")));
  expect_same(read_volume(scratch("bomtg.node")), m);
  write_file(scratch("bom_lm.txt"), bom + "3\n5\n");
  EXPECT_EQ(read_landmarks(scratch("bom_lm.txt"), s.V), (std::vector<int>{3, 5}));
  write_file(scratch("bom_pts.txt"), bom + "1 2 3\r\n\r\n  \r\n# c\r\n4 5 6\r\n");
  const Eigen::MatrixXd P = read_points(scratch("bom_pts.txt"));
  ASSERT_EQ(P.rows(), 2);
  EXPECT_EQ(P(1, 2), 6.0);
}

TEST(IO, PointsFileErrorsNameTheLine) {
  const std::string p = scratch("pts.txt");
  write_file(p, "1 2 3\n4 5 6 7\n");
  EXPECT_EQ(error_of([&] { read_points(p); }), p + ":2: expected 3 values (x y z), found more");
  write_file(p, "1 2 3\n4 5\n");
  EXPECT_EQ(error_of([&] { read_points(p); }), p + ":2: expected z, found end of line");
  write_file(p, "# none\n\n");
  EXPECT_EQ(error_of([&] { read_points(p); }), p + ": no points");
}

// VTK's own reader takes keywords in any case; so do we.
TEST(IO, VtkKeywordsInAnyCase) {
  TetMesh m = grid_tets();
  const std::string p = scratch("kw.vtk");
  write_volume(p, m);
  std::string text = read_bytes(p);
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"POINTS", "points"}, {"CELLS", "cells"},
                                 {"CELL_TYPES", "Cell_Types"}, {" double", " DOUBLE"}}) {
    const size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
  }
  write_file(p, text);
  expect_same(read_volume(p), m);
}

// TetGen pairs in any letter case: the given file as named, its companion in the same case
// (or in another if only that one exists).
TEST(IO, TetgenExtensionsInAnyCase) {
  TetMesh m = grid_tets();
  write_volume(scratch("tgc.node"), m);
  for (const auto& [node, ele] : {std::pair<std::string, std::string>{"Cap.Node", "Cap.Ele"},
                                  {"Up.NODE", "Up.ELE"}, {"Mix.NODE", "Mix.ele"}}) {
    std::filesystem::copy_file(scratch("tgc.node"), scratch(node));
    std::filesystem::copy_file(scratch("tgc.ele"), scratch(ele));
    expect_same(read_volume(scratch(node)), m);
    expect_same(read_volume(scratch(ele)), m);
  }
}

// Damage that used to read silently: "f1 2 3" (dropped as an unknown statement) and a .ele
// header announcing 10 nodes per tet over 4-node lines.
TEST(IO, FusedObjKeywordAndShortTenNodeTets) {
  const std::string p = scratch("fused.obj");
  write_surface(p, octahedron());
  write_file(p, read_bytes(p) + "f1 2 3\n");
  EXPECT_NE(error_of([&] { read_surface(p); }).find(": not an OBJ statement: 'f1' (missing space after 'f'?)"), std::string::npos)
      << error_of([&] { read_surface(p); });
  const std::string node = scratch("ten.node"), ele = scratch("ten.ele");
  write_file(node, "5 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 1 1 1\n");
  write_file(ele, "1 10 0\n1 1 2 3 4\n");
  EXPECT_EQ(error_of([&] { read_volume(node); }), ele + ":2: expected tetrahedron node, found end of line");
}

// Numbers below the double range read as 0 (as strtod gives them); above it they are an
// error. Messages print numbers short.
TEST(IO, UnderflowReadsAsZeroAndMessagesStayShort) {
  const std::string p = scratch("tiny.obj");
  write_file(p, "v 1e-400 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_EQ(read_surface(p).V(0, 0), 0.0);
  write_file(p, "v 1e400 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_EQ(error_of([&] { read_surface(p); }), p + ":1: vertex x '1e400' is out of range");
  BarycentricMap m;
  m.elem = Eigen::VectorXi::Zero(1);
  m.bary = Eigen::MatrixXd(1, 3);
  m.bary << 1e308, 0, 0;
  try {
    validate_map(m, 1, 1, 3, "m");
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "m: vertex 0 has barycentric coordinates summing to 1e+308, not 1");
  }
}

// Old Mac line ends (a lone \r) separate lines like \n and \r\n, with the same line numbers.
TEST(IO, LoneCarriageReturnEndsALine) {
  TriMesh s = octahedron();
  for (const char* ext : {".obj", ".off"}) {
    const std::string p = scratch(std::string("cr_plain") + ext), q = scratch(std::string("cr") + ext);
    write_surface(p, s);
    std::string text = read_bytes(p);
    std::replace(text.begin(), text.end(), '\n', '\r');
    write_file(q, text);
    expect_same(read_surface(q), s);
  }
  const std::string q = scratch("cr_bad.obj");
  write_file(q, "v 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 9\r");
  EXPECT_EQ(error_of([&] { read_surface(q); }), q + ":4: face index 9 out of range (3 vertices)");
}
