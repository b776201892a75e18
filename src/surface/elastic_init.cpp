// Landmark-driven initial maps for elastic correspondence: BIM with the landmarks
// (BIMOptions::landmark_feature_points: guided by them, or over their triplets alone).
#include "shapemap/error.h"
#include "shapemap/surface/bim.h"
#include "shapemap/surface/elastic.h"

#include <string>

namespace shapemap {

void landmark_initial_maps(const TriMesh& A, const TriMesh& B, const std::vector<int>& la,
                           const std::vector<int>& lb, BarycentricMap& init_AB,
                           BarycentricMap& init_BA, const BIMOptions* bim) {
  if (la.size() != lb.size())
    throw InputError("landmarks: " + std::to_string(la.size()) + " on A but " +
                     std::to_string(lb.size()) + " on B");
  if (la.size() < 3) throw InputError("landmarks: at least 3 correspondences are needed");
  for (int v : la)
    if (v < 0 || v >= A.num_vertices())
      throw InputError("landmarks: vertex " + std::to_string(v) + " out of range on A");
  for (int v : lb)
    if (v < 0 || v >= B.num_vertices())
      throw InputError("landmarks: vertex " + std::to_string(v) + " out of range on B");
  BIMOptions o = bim ? *bim : BIMOptions{};
  o.landmarks_A = la;
  o.landmarks_B = lb;
  o.symmetric = true;
  BIMResult r = blended_intrinsic_maps(A, B, o);
  init_AB = r.AB.map;
  init_BA = r.BA.map;
}

}  // namespace shapemap
