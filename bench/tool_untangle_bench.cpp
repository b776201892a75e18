// The untangling stages of the elastic method (surface/refine_surface_maps.h, stages 2 to 5)
// on saved maps, without rerunning the refinement (issue 20). Reads the input surfaces and the
// maps of `surface-map --method elastic --elastic-no-untangle` (the inputs' numbering),
// repairs the surfaces as the command does, runs the stages, and prints per direction the
// flipped + collapsed triangles after each stage (on the repaired surfaces, as report.json,
// and on the inputs, as bench/surface_real.sh) and the round trip: the mean over A's vertices
// of |Q(P(x)) - x| over A's bounding-box diagonal, on the inputs, as bench/surface_real.sh.
// Usage: tool_untangle_bench A B map_AB map_BA [--no-wide] [--no-bridges] [--no-search] [--sliver-mips M] [--passes N] [-o DIR]
// (--no-bridges: no stage 5; --bridge-sweeps N, --bridge-rings N: its sweeps and rings)
// (--no-search: no stage 6; --search-sweeps N, --search-grid N, --search-rings N,
// --search-max-mips M: its UntangleOptions search_sweeps, search_grid, search_rings,
// search_max_mips)
// (--passes: SurfaceRefinementOptions::untangle_passes, default 3)
// (--reverse-weight W, --tether T: UntangleOptions::reverse_weight / tether of every stage)
// (--sliver-mips: stage 4's threshold, 0 skips stage 4)
// (-o: writes the resulting map_AB.txt and map_BA.txt there, inputs' numbering).
#include "shapemap/openmp_policy.h"
#include "shapemap/eval/surface_distortion.h"
#include "shapemap/io.h"
#include "shapemap/repair.h"
#include "shapemap/surface/refine_surface_maps.h"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>

using namespace shapemap;

namespace {
int bad(const TriMesh& S, const TriMesh& T, const BarycentricMap& P) {
  const SurfaceDistortion d = surface_distortion(S, T, P);
  return d.flipped + d.degenerate;
}
double conformal(const TriMesh& S, const TriMesh& T, const BarycentricMap& P) {
  return surface_distortion(S, T, P).conformal_mean;
}
double round_trip(const TriMesh& A, const TriMesh& B, const BarycentricMap& P, const BarycentricMap& Q) {
  const Eigen::MatrixXd PQX = map_positions(P, map_positions(Q, A.V, A.F), B.F);
  const double diag = (A.V.colwise().maxCoeff() - A.V.colwise().minCoeff()).norm();
  return ((PQX - A.V).rowwise().norm() / diag).mean();
}
}  // namespace

int main(int argc, char** argv) {
  shapemap::use_passive_openmp_wait(argv);  // as the CLI runs (openmp_policy.h)
  if (argc < 5) {
    std::fprintf(stderr, "usage: tool_untangle_bench A B map_AB map_BA [--no-wide] [--no-bridges] [--no-search] [--sliver-mips M] "
                 "[--passes N] [--reverse-weight W] [--tether T] [-o DIR]\n");
    return 2;
  }
  SurfaceRefinementOptions opt;
  std::string out;
  for (int i = 5; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--no-wide")) opt.wide_untangle = false;
    else if (!std::strcmp(argv[i], "--no-bridges")) opt.bridge_untangle = false;
    else if (!std::strcmp(argv[i], "--no-search")) opt.search_untangle = false;
    else if (!std::strcmp(argv[i], "--search-sweeps") && i + 1 < argc)
      opt.search_untangling.search_sweeps = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--search-max-mips") && i + 1 < argc)
      opt.search_untangling.search_max_mips = std::atof(argv[++i]);
    else if (!std::strcmp(argv[i], "--search-rings") && i + 1 < argc)
      opt.search_untangling.search_rings = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--search-grid") && i + 1 < argc)
      opt.search_untangling.search_grid = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--bridge-sweeps") && i + 1 < argc)
      opt.bridge_untangling.sweeps = opt.bridge_untangling.smooth_sweeps = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--bridge-rings") && i + 1 < argc) opt.bridge_untangling.rings = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--passes") && i + 1 < argc) opt.untangle_passes = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "-o") && i + 1 < argc) out = argv[++i];
    else if (!std::strcmp(argv[i], "--sliver-mips") && i + 1 < argc)
      opt.sliver_untangling.sliver_mips = std::atof(argv[++i]);  // 0: no stage 4
    else if (!std::strcmp(argv[i], "--reverse-weight") && i + 1 < argc) {
      const double w = std::atof(argv[++i]);
      opt.untangling.reverse_weight = opt.wide_untangling.reverse_weight = opt.sliver_untangling.reverse_weight =
          opt.bridge_untangling.reverse_weight = w;
    } else if (!std::strcmp(argv[i], "--tether") && i + 1 < argc) {
      const double w = std::atof(argv[++i]);
      opt.untangling.tether = opt.wide_untangling.tether = opt.sliver_untangling.tether =
          opt.bridge_untangling.tether = w;
    }
  }
  if (!(opt.sliver_untangling.sliver_mips > 0)) opt.sliver_untangle = false;
  const TriMesh A = read_surface(argv[1]), B = read_surface(argv[2]);
  const SurfaceRepair rA = repair_surface(A, "A"), rB = repair_surface(B, "B");
  BarycentricMap P = map_to_repaired(read_map(argv[3]), rA, rB, B);
  BarycentricMap Q = map_to_repaired(read_map(argv[4]), rB, rA, A);
  const TriMesh &RA = rA.mesh, &RB = rB.mesh;
  auto line = [&](const char* what) {
    const BarycentricMap iP = map_to_inputs(P, rA, rB, B), iQ = map_to_inputs(Q, rB, rA, A);
    std::printf("%-12s repaired AB %4d BA %4d | inputs AB %4d BA %4d | round trip AB %.4f%% BA %.4f%% | "
                "conformal AB %.4g BA %.4g\n", what, bad(RA, RB, P), bad(RB, RA, Q), bad(A, B, iP), bad(B, A, iQ),
                100 * round_trip(A, B, iP, iQ), 100 * round_trip(B, A, iQ, iP), conformal(A, B, iP),
                conformal(B, A, iQ));
  };
  line("refined");
  const auto t0 = std::chrono::steady_clock::now();
  const SurfaceUntangling u = untangle_surface_maps(RA, RB, P, Q, opt);
  const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  line("untangled");
  std::printf("stage 2: AB %d -> %d, BA %d -> %d; slivers AB %d -> %d, BA %d -> %d\n", u.AB.before.bad(),
              u.AB.after.bad(), u.BA.before.bad(), u.BA.after.bad(), u.AB.slivers_before, u.AB.slivers_after,
              u.BA.slivers_before, u.BA.slivers_after);
  if (u.wide)
    std::printf("stage 3: AB %d -> %d (%d of %d regions kept), BA %d -> %d (%d of %d)\n", u.wide_AB.before.bad(),
                u.wide_AB.after.bad(), u.wide_AB.regions_kept, u.wide_AB.regions, u.wide_BA.before.bad(),
                u.wide_BA.after.bad(), u.wide_BA.regions_kept, u.wide_BA.regions);
  if (u.slivers)
    std::printf("stage 4: slivers AB %d -> %d (folds %d -> %d), BA %d -> %d (folds %d -> %d)\n",
                u.sliver_AB.slivers_before, u.sliver_AB.slivers_after, u.sliver_AB.before.bad(),
                u.sliver_AB.after.bad(), u.sliver_BA.slivers_before, u.sliver_BA.slivers_after,
                u.sliver_BA.before.bad(), u.sliver_BA.after.bad());
  if (u.bridges)
    std::printf("stage 5: AB %d -> %d (%d of %d regions kept), BA %d -> %d (%d of %d)\n", u.bridge_AB.before.bad(),
                u.bridge_AB.after.bad(), u.bridge_AB.regions_kept, u.bridge_AB.regions, u.bridge_BA.before.bad(),
                u.bridge_BA.after.bad(), u.bridge_BA.regions_kept, u.bridge_BA.regions);
  if (u.search)
    std::printf("stage 6: AB %d -> %d (%d vertices moved), BA %d -> %d (%d)\n", u.search_AB.before.bad(),
                u.search_AB.after.bad(), u.search_AB.vertices_moved, u.search_BA.before.bad(),
                u.search_BA.after.bad(), u.search_BA.vertices_moved);
  std::printf("passes %d, seconds %.1f\n", u.passes, sec);
  if (!out.empty()) {
    std::filesystem::create_directories(out);  // (a missing folder used to abort the tool)
    write_map(out + "/map_AB.txt", map_to_inputs(P, rA, rB, B));
    write_map(out + "/map_BA.txt", map_to_inputs(Q, rB, rA, A));
  }
  return 0;
}
