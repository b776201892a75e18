// The notes tetrahedralize() leaves for the user (TetrahedralizeInfo -> one line each).
#include "shapemap/volume/tetrahedralize.h"

namespace shapemap {

std::vector<std::string> tetrahedralize_notes(const TetrahedralizeInfo& ti, const std::string& name) {
  std::vector<std::string> notes;
  const std::string note = name + ": note: ";
  if (ti.self_intersecting_pairs > 0)
    notes.push_back(note + "the surface crosses itself (" + std::to_string(ti.self_intersecting_pairs) +
                    (ti.self_intersections_removed
                         ? " pairs of faces); meshing ran away, so the crossings were removed (CGAL) and it was "
                           "meshed again"
                         : " pairs of faces); meshed the region inside it by ray parity, without crease "
                           "protection"));
  if (ti.touching_vertices > 0)
    notes.push_back(note + "the surface touches itself (" + std::to_string(ti.touching_vertices) +
                    " vertices at the position of another); meshed without Mesh_3's manifold criterion and "
                    "without crease protection, so the boundary of the tet mesh may have non-manifold edges there");
  if (!ti.creases_dropped.empty())
    notes.push_back(note + "sharp creases not protected (CGAL's crease protection failed: " + ti.creases_dropped +
                    "); meshed without them");
  if (!ti.manifold_dropped.empty())
    notes.push_back(note + "meshing with Mesh_3's manifold criterion ran away (" + ti.manifold_dropped +
                    "); meshed without it, so the boundary of the tet mesh may have non-manifold edges");
  if (!ti.odt_dropped.empty())
    notes.push_back(note + "the ODT-smoothed mesh was not valid (" + ti.odt_dropped +
                    "); meshed without ODT smoothing");
  return notes;
}

}  // namespace shapemap
