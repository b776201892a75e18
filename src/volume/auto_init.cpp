// The automatic initialization of symmetric volume maps: a surface map between the two
// boundary surfaces, by blended intrinsic maps (blended-intrinsic-maps.txt, both
// directions) refined by bijective elastic correspondence (elastic-correspondence.txt) with
// the same final stages as `surface-map --method elastic` (refine_surface_maps.h: the collapse
// guard and the untangling of the returned maps).
// The volume paper (Sec. 5.1) takes such a surface map as given; this makes the volume
// pipeline fully automatic.
#include "shapemap/error.h"
#include "shapemap/surface/bim.h"
#include "shapemap/surface/elastic.h"
#include "shapemap/surface/refine_surface_maps.h"
#include "shapemap/surface/surface_map_pipeline.h"
#include "shapemap/volume/symmetric_map.h"

#include <sstream>

namespace shapemap {

std::pair<BarycentricMap, BarycentricMap> surface_map_for_volumes(const TriMesh& SA,
                                                                  const TriMesh& SB,
                                                                  const ProgressCallback& progress,
                                                                  std::string* used,
                                                                  bool elastic_refinement,
                                                                  const ElasticSettings* elastic,
                                                                  const std::vector<int>& landmarks_A,
                                                                  const std::vector<int>& landmarks_B,
                                                                  bool reverse_candidates) {
  BIMOptions bo;
  bo.symmetric = true;
  std::pair<BarycentricMap, BarycentricMap> maps;
  const bool landmarks = !landmarks_A.empty();
  // Without landmarks as surface-map: two directions that agree (docs/methods.md, "Animals and
  // the choice of direction"). With landmarks each direction's own blend (BIM guided by them):
  // the inverse cost both landmark pairs of the volume bench d-hat and E_R ("The automatic
  // start's two directions").
  bo.reverse_candidates = reverse_candidates && !landmarks;
  const std::string bim_name = std::string(!landmarks ? "BIM"
                                            : bim_landmark_guided(bo, int(landmarks_A.size())) ? "BIM guided by landmarks"
                                                                                                : "BIM over landmark triplets") +
                               (bo.reverse_candidates ? " (reverse candidates)" : "");
  if (landmarks) {  // the user's correspondences guide BIM, as in surface-map
    landmark_initial_maps(SA, SB, landmarks_A, landmarks_B, maps.first, maps.second, &bo);
    if (used) *used = bim_name;
  } else {
    BIMResult bim = blended_intrinsic_maps(SA, SB, bo, progress);
    maps = {bim.AB.map, bim.BA.map};
    if (used) *used = bim_name;
  }
  const BarycentricMap initAB = maps.first, initBA = maps.second;
  if (!elastic_refinement) return maps;
  // The surface-map command's elastic defaults unless given, its bending weight rule included
  // (Sec. 5.2: BIM maps usually have flipped triangles, so usually the smaller eta).
  const ElasticSettings settings = elastic ? *elastic : ElasticSettings{};
  SurfaceRefinementOptions ro;
  set_refinement_stages(settings, ro);
  std::string eta_choice;
  try {
    ro.elastic = elastic_options_from_settings(settings, SA, SB, initAB, initBA, true, eta_choice);
    ro.elastic.progress = progress;
    if (landmarks && ro.feature_anchors) {  // the landmarks are the anchors (stage 0)
      ro.elastic.anchors.A = landmarks_A;
      ro.elastic.anchors.B = landmarks_B;
    }
    const SurfaceRefinement ref = refine_surface_maps(SA, SB, initAB, initBA, ro);
    const ElasticResult& el = ref.elastic;
    if (el.map_AB.size() == SA.num_vertices() && el.map_BA.size() == SB.num_vertices()) {
      maps = {el.map_AB, el.map_BA};
      if (used) {
        std::ostringstream s;
        s << bim_name << " + elastic (eta " << ro.elastic.eta << ", "
          << eta_choice << ")";
        if (landmarks && ro.feature_anchors) s << ", " << landmarks_A.size() << " landmarks as anchors";
        if (ref.untangled)
          s << " + untangle (flipped + collapsed A->B " << ref.untangling.AB.before.bad() << " -> "
            << ref.untangling.final_AB.bad() << ", B->A " << ref.untangling.BA.before.bad() << " -> "
            << ref.untangling.final_BA.bad() << ")";
        *used = s.str();
      }
    }
  } catch (const Error&) {
    // Elastic refinement failed internally: keep the BIM maps (reported through `used`).
    if (used) *used = bim_name + " (elastic refinement failed)";
  }
  return maps;
}

}  // namespace shapemap
