// Parts of a surface map that are collapsed, put back at their own shape (ours; docs/methods.md,
// "Thin parts: collapsed parts re-extended"). BIM blends Möbius maps, and a Möbius map shrinks a
// long thin part (the arm of a pair of glasses) to a tiny region of the sphere: the blend sends
// the whole part to a point or a ring of the other surface, and stretches the band beside it
// over the other's part (the paper's Fig. 14 names this failure). The elastic refinement cannot
// undo it: a collapsed region has no membrane forces. Here, before the refinement:
//   1. a face of A is degenerate under the map when a singular value of the map's Jacobian,
//      over the global scale sqrt(area(B) / area(A)), is below 1 / stretch_limit or above
//      stretch_limit; a vertex is degenerate when at least half of its faces are;
//   2. connected regions of degenerate vertices of at least min_area of A's area are grown by
//      grow_rings rings (to take in the stretched band and reach well-mapped vertices);
//   3. each region is placed by the rotation and translation that best fit (Kabsch) A's next
//      handle_rings rings, scaled, to their images: the part continues the rigid motion of
//      what it is attached to;
//   4. as-rigid-as-possible (Sorkine & Alexa 2007; cotangent weights without negative ones)
//      from A's shape, scaled, with every vertex outside the regions held at its image;
//   5. the regions' vertices go to their closest points on B.
// The elastic refinement then starts from a map that spreads the part over the other's part.
#pragma once
#include "shapemap/maps.h"
#include "shapemap/mesh.h"

namespace shapemap {

struct CollapsedPartOptions {
  double stretch_limit = 10;  // step 1
  double min_area = 0.005;    // step 2: share of A's area
  int grow_rings = 4;         // step 2
  int handle_rings = 3;       // step 3
  int arap_iterations = 40;   // step 4: local-global iterations
};

struct CollapsedPartResult {
  int regions = 0;           // regions re-extended
  int vertices = 0;          // vertices given new images (the grown regions)
  int degenerate_faces = 0;  // step 1's count, over all of A
  double seconds = 0;
};

// A, B: closed triangle meshes; map: A's vertices on B's faces. Returns the map with the
// regions' rows replaced (the same map when there is none).
BarycentricMap reextend_collapsed_parts(const TriMesh& A, const TriMesh& B, const BarycentricMap& map,
                                        const CollapsedPartOptions& opt = {}, CollapsedPartResult* result = nullptr);

}  // namespace shapemap
