// Barycentric maps: positions against a hand computation, validation messages, and
// the map file format (exact round trip, errors).
#include "io_test_util.h"
#include "shapemap/error.h"
#include "shapemap/io.h"
#include "shapemap/maps.h"
#include <gtest/gtest.h>

using namespace shapemap;
using namespace shapemap::testing;

TEST(Maps, PositionsAreBarycentricCombinations) {
  TriMesh m = octahedron();
  BarycentricMap map;
  map.elem.resize(2);
  map.elem << 0, 5;
  map.bary.resize(2, 3);
  map.bary << 1, 0, 0, 0.2, 0.3, 0.5;
  Eigen::MatrixXd X = map_positions(map, m.V, m.F);
  EXPECT_TRUE(X.row(0) == m.V.row(m.F(0, 0)));
  Eigen::RowVector3d ref = 0.2 * m.V.row(m.F(5, 0)) + 0.3 * m.V.row(m.F(5, 1)) + 0.5 * m.V.row(m.F(5, 2));
  EXPECT_NEAR((X.row(1) - ref).norm(), 0, 1e-15);
  TetMesh t = cube_tets();
  BarycentricMap vm;
  vm.elem = Eigen::VectorXi::Constant(1, 3);
  vm.bary = Eigen::RowVector4d(0.25, 0.25, 0.25, 0.25);
  Eigen::MatrixXd Y = map_positions(vm, t.V, t.T);
  Eigen::RowVector3d c = Eigen::RowVector3d::Zero();
  for (int j = 0; j < 4; ++j) c += 0.25 * t.V.row(t.T(3, j));
  EXPECT_NEAR((Y.row(0) - c).norm(), 0, 1e-15);
  map.elem(1) = 8;
  EXPECT_THROW(map_positions(map, m.V, m.F), Error);
}

TEST(Maps, Validation) {
  BarycentricMap map;
  map.elem = Eigen::VectorXi::Zero(3);
  map.bary = Eigen::MatrixXd::Constant(3, 3, 1.0 / 3);
  EXPECT_NO_THROW(validate_map(map, 3, 1, 3, "m.txt"));
  EXPECT_EQ(message_of([&] { validate_map(map, 4, 1, 3, "m.txt"); }),
            "m.txt: map has 3 entries, the source mesh has 4 vertices");
  EXPECT_EQ(message_of([&] { validate_map(map, 3, 1, 4, "m.txt"); }),
            "m.txt: map has 3 barycentric coordinates per vertex, expected 4 (a volume map)");
  map.elem(2) = 1;
  EXPECT_EQ(message_of([&] { validate_map(map, 3, 1, 3, "m.txt"); }),
            "m.txt: vertex 2 maps to element 1, out of range (1 target elements)");
  map.elem(2) = 0;
  map.bary.row(1) << 0.5, 0.6, -0.1;
  EXPECT_NE(message_of([&] { validate_map(map, 3, 1, 3, "m.txt"); }).find("vertex 1 has a negative"), std::string::npos);
  map.bary.row(1) << 0.5, 0.6, 1e-7;
  EXPECT_NE(message_of([&] { validate_map(map, 3, 1, 3, "m.txt"); }).find("summing to"), std::string::npos);
  map.bary.row(1) << 0.5, 0.5, -1e-7;  // within tolerance
  EXPECT_NO_THROW(validate_map(map, 3, 1, 3, "m.txt"));
}

TEST(Maps, FileRoundTripIsExact) {
  for (int arity : {3, 4}) {
    BarycentricMap map;
    map.elem.resize(50);
    map.bary.resize(50, arity);
    for (int i = 0; i < 50; ++i) {
      map.elem(i) = (i * 37) % 101;
      Eigen::RowVectorXd b = Eigen::RowVectorXd::LinSpaced(arity, 1.0 + i, 2.0 + 3.0 * i);
      map.bary.row(i) = b / b.sum();
    }
    std::string p = scratch("map" + std::to_string(arity) + ".txt");
    write_map(p, map);
    BarycentricMap r = read_map(p);
    EXPECT_TRUE(r.elem == map.elem);
    EXPECT_TRUE(r.bary == map.bary);
    EXPECT_EQ(r.arity(), arity);
    EXPECT_NO_THROW(validate_map(r, 50, 101, arity, p));
  }
}

TEST(Maps, FileErrors) {
  std::string p = scratch("bad_map.txt");
  write_file(p, "# c\nshapemap-map 1 2 3\n0 0.5 0.5 0\n1 1 0\n");
  EXPECT_EQ(message_of([&] { read_map(p); }), p + ":4: expected barycentric coordinate, found end of line");
  write_file(p, "shapemap-map 1 2 3\n0 0.5 0.5 0\n");
  EXPECT_NE(message_of([&] { read_map(p); }).find(p + ":2: map entry count 2 does not fit"), std::string::npos);
  write_file(p, "shapemap-map 1 3 3\n0 0.5 0.5 0\n# a long comment that pads the file\n");
  EXPECT_EQ(message_of([&] { read_map(p); }), p + ":4: file ends after 1 of 3 entries: truncated");
  write_file(p, "shapemap-map 1 1 3\n0 0.5 0.5 0\n1 1 0 0\n");
  EXPECT_EQ(message_of([&] { read_map(p); }), p + ":3: more entries than the header's 1");
  write_file(p, "shapemap-map 1 1 5\n");
  EXPECT_EQ(message_of([&] { read_map(p); }), p + ":1: arity 5 (need 3 for surfaces, 4 for volumes)");
  write_file(p, "0 1 0 0\n");
  EXPECT_NE(message_of([&] { read_map(p); }).find(p + ":1: not a shapemap map file"), std::string::npos);
  write_file(p, "shapemap-map 1 1 3\n-3 1 0 0\n");
  EXPECT_EQ(message_of([&] { read_map(p); }), p + ":2: element index -3 out of range");
  write_file(p, "shapemap-map 1 1 3\n0 1 0 0 7\n");
  EXPECT_EQ(message_of([&] { read_map(p); }), p + ":2: more than 4 values on an entry line");
}
