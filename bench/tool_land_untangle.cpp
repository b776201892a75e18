// The volume map's last landing step (foldover_free.h, untangle_in_target) on saved map
// files, without rerunning the optimization (issue 19): reads the source and target tet
// meshes and a map file of `volume-map` (source vertex -> target tet + barycentric
// coordinates), untangles the map around its inverted tets in the unit-volume frames the
// solver uses, locates the result in the target's tets as the landing does, and prints the
// inverted tets before and after, the largest move over the target's bounding-box diagonal,
// and the time. Exit 1 when the result inverts more tets than the input.
// Usage: tool_land_untangle A.vtk B.vtk map_AB.txt [--rings R (the most rings: 1, 2, 4, ..., R)] [-o map_out.txt]
#include "shapemap/openmp_policy.h"
#include "shapemap/adjacency.h"
#include "shapemap/io.h"
#include "shapemap/maps.h"
#include "shapemap/volume/foldover_free.h"
#include "shapemap/volume/symmetric_map.h"

#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>

using namespace shapemap;

int main(int argc, char** argv) {
  shapemap::use_passive_openmp_wait(argv);  // as the CLI runs (openmp_policy.h)
  if (argc < 4) {
    std::fprintf(stderr, "usage: tool_land_untangle A.vtk B.vtk map_AB.txt [--rings R] [-o map_out.txt]\n");
    return 2;
  }
  int rings = 8;
  std::string out;
  for (int a = 4; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--rings") && a + 1 < argc) rings = std::atoi(argv[++a]);
    else if (!std::strcmp(argv[a], "-o") && a + 1 < argc) out = argv[++a];
  }
  try {
    const TetMesh A = read_volume(argv[1]), B = read_volume(argv[2]);
    const BarycentricMap map = read_map(argv[3]);
    const Normalization nA = unit_volume_normalization(A), nB = unit_volume_normalization(B);
    const TetMesh Mi{nA.apply(A.V), A.T}, Mj{nB.apply(B.V), B.T};
    const ArapEnergy arap(Mi.V, Mi.T);
    const TetBoundary bi = boundary_surface(Mi), bj = boundary_surface(Mj);
    std::vector<char> on_bd(Mi.num_vertices(), 0);
    for (int i = 0; i < bi.to_volume.size(); ++i) on_bd[bi.to_volume(i)] = 1;
    const ClosestPoint3 surface(bj.surface.V, bj.surface.F);
    const TetLocator locator(Mj.V, Mj.T);
    const Eigen::MatrixXd X0 = map_positions(map, Mj.V, Mj.T);
    Eigen::MatrixXd Y = X0;
    auto inverted = [&](const Eigen::MatrixXd& P) {
      const Eigen::VectorXd d = arap.determinants(P);
      return int((d.array() <= 0).count());
    };
    const int before = inverted(X0);
    const auto t0 = std::chrono::steady_clock::now();
    // As the landing: 1, 2, 4, ... rings, each from the best map so far, located (rows that
    // moved in M_j's tets, clamped if outside; the others keep their entries) and kept when
    // it inverts fewer tets.
    BarycentricMap located = map;
    Eigen::MatrixXd P = X0;
    int after = before, outside = 0, rounds = 0;
    for (int r = 1; r <= rings && after > 0; r *= 2) {
      Eigen::MatrixXd Y = P;
      rounds += untangle_in_target(arap, vertex_neighbors(Mi.T, Mi.num_vertices()), on_bd,
                                   InTarget{Mj, bj.surface, surface, locator}, r, 1e-6, FoldoverFreeOptions{}, Y)
                    .rounds;
      std::vector<int> moved;
      for (int v = 0; v < Mi.num_vertices(); ++v)
        if (Y.row(v) != P.row(v)) moved.push_back(v);
      Eigen::MatrixXd Ym(moved.size(), 3);
      for (size_t q = 0; q < moved.size(); ++q) Ym.row(Eigen::Index(q)) = Y.row(moved[q]);
      int out_r = 0;
      const BarycentricMap lm = locate_in_tets(Mj, Ym, {}, &out_r);
      BarycentricMap m = located;
      for (size_t q = 0; q < moved.size(); ++q) {
        m.elem(moved[q]) = lm.elem(Eigen::Index(q));
        m.bary.row(moved[q]) = lm.bary.row(Eigen::Index(q));
      }
      const Eigen::MatrixXd Pm = map_positions(m, Mj.V, Mj.T);
      const int c = inverted(Pm);
      std::printf("  rings %d: %d inverted (%d outside)\n", r, c, out_r);
      if (c < after) {
        after = c;
        located = m;
        P = Pm;
        outside = out_r;
      }
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const double move = (P - X0).rowwise().norm().maxCoeff() / bbox_diagonal(Mj.V);
    std::printf("%s: inverted %d -> %d, rounds %d, outside %d, max move %.3g of the diagonal, %.2f s\n", argv[3],
                before, after, rounds, outside, move, seconds);
    if (!out.empty()) write_map(out, located);
    return after > before ? 1 : 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tool_land_untangle: %s\n", e.what());
    return 2;
  }
}
