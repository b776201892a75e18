// The automatic initialization of symmetric volume maps: a surface map between the two
// boundary surfaces, by blended intrinsic maps (blended-intrinsic-maps.txt, both
// directions) refined by bijective elastic correspondence (elastic-correspondence.txt).
// The volume paper (Sec. 5.1) takes such a surface map as given; this makes the volume
// pipeline fully automatic.
#include "shapemap/error.h"
#include "shapemap/surface/bim.h"
#include "shapemap/surface/elastic.h"
#include "shapemap/volume/symmetric_map.h"

#include <sstream>

namespace shapemap {

std::pair<BarycentricMap, BarycentricMap> surface_map_for_volumes(const TriMesh& SA,
                                                                  const TriMesh& SB,
                                                                  const ProgressCallback& progress,
                                                                  std::string* used,
                                                                  bool elastic_refinement) {
  BIMOptions bo;
  bo.symmetric = true;
  // Each direction's own blend, as measured for the volume maps (BIMOptions::reverse_candidates,
  // the surface-map default since 3 Dec 2026, has not been measured on the volume benches).
  bo.reverse_candidates = false;
  BIMResult bim = blended_intrinsic_maps(SA, SB, bo, progress);
  std::pair<BarycentricMap, BarycentricMap> maps{bim.AB.map, bim.BA.map};
  if (used) *used = "BIM";
  if (!elastic_refinement) return maps;
  ElasticOptions eo;
  eo.progress = progress;
  try {
    // BIM maps usually have flipped triangles: Sec. 5.2's smaller bending weight (elastic.h).
    eo.eta = bending_weight_for_initial_maps(SA, SB, bim.AB.map, bim.BA.map, eo.eta).eta;
    ElasticResult el = elastic_correspondence(SA, SB, bim.AB.map, bim.BA.map, eo);
    if (el.map_AB.size() == SA.num_vertices() && el.map_BA.size() == SB.num_vertices()) {
      maps = {el.map_AB, el.map_BA};
      if (used) {
        std::ostringstream s;
        s << "BIM + elastic (eta " << eo.eta << ", Sec. 5.2 rule)";
        *used = s.str();
      }
    }
  } catch (const Error&) {
    // Elastic refinement failed internally: keep the BIM maps (reported through `used`).
    if (used) *used = "BIM (elastic refinement failed)";
  }
  return maps;
}

}  // namespace shapemap
