// The whole volume-map command as library calls, shared by `shapemap volume-map` and the
// Python module (symmetric-volume-maps.txt): volume inputs (tet meshes, or closed surfaces
// repaired and tetrahedralized), landmarks carried from a surface to its tet mesh, the four
// initializations (auto / landmarks / ball / surface-map), Algorithm 1, and the Table 3
// metrics as report.json holds them. No files, no printing: notes are returned.
#pragma once
#include "shapemap/eval/volume_metrics.h"
#include "shapemap/maps.h"
#include "shapemap/mesh.h"
#include "shapemap/progress.h"
#include "shapemap/volume/ball_param.h"
#include "shapemap/volume/symmetric_map.h"
#include <nlohmann/json.hpp>
#include <cstdint>
#include <string>
#include <vector>

namespace shapemap {

// One side of a volume map.
struct VolumeInput {
  std::string name = "A";           // for messages (the file path in the CLI)
  TetMesh mesh;                     // what the maps index
  bool from_surface = false;
  TriMesh surface;                  // from_surface: the repaired surface that was tetrahedralized
  TriMesh given;                    // from_surface: the surface as given (landmarks refer to it)
  std::vector<std::string> repairs; // notes of the input repairs (report.json: inputs.repairs)
  std::vector<std::string> notes;   // other notes (bad tets accepted, tetrahedralization)
};

// A tet mesh as given: up to 1% inverted or degenerate tets are accepted (with a note);
// more, or indices out of range, throw InputError("<name>: ...").
VolumeInput volume_input_from_tets(TetMesh mesh, const std::string& name);

// A closed genus-0 surface: safe repairs (strict: refuse), then tetrahedralized with about
// `tets` tets (0: default) and `seed`. Throws InputError("<name>: ...").
VolumeInput volume_input_from_surface(const TriMesh& given, const std::string& name, int tets,
                                      std::uint64_t seed, bool strict, const ProgressCallback& progress = {});

// Landmarks of a surface input, as vertices of its given surface, carried to the nearest
// boundary vertex of the tet mesh made from it (Mesh_3 remeshes the surface, so the
// numberings differ). For a tet-mesh input the indices are returned as they are.
std::vector<int> carry_landmarks_to_volume(const VolumeInput& in, const std::vector<int>& landmarks);

// Whether landmarks are too few for the landmark initialization: Sec. 5.1 sends every vertex to
// its nearest landmark's partner, a start made of as many points as there are landmarks, which
// the optimization does not recover from with fewer than kLandmarkStartMinPairs distinct pairs
// (cat -> lion with 4 to 16 of its 20 landmarks, the busts with 4, airplane -> bird with 3:
// docs/methods.md, "Few landmarks: the automatic start guided by them"). The default
// initialization with landmarks is then auto guided by them, with this note (`volume-map`
// without --init, Python's volume_map without init). The automatic start maps the boundaries
// with BIM, so from 4 pairs up it is chosen only when both surfaces it would map (the boundaries,
// or the given surfaces, after the safe repairs) are closed genus-0 surfaces (below 4 the
// landmark start is flat, and auto is the one start that can work).
constexpr int kLandmarkStartMinPairs = 20;
bool sparse_landmark_start(std::vector<int> LA, std::vector<int> LB, const VolumeInput& A, const VolumeInput& B,
                           bool strict);
std::string sparse_landmark_start_note();

struct VolumeMapRequest {
  std::string init = "auto";          // auto | landmarks | ball | surface-map (Sec. 5.1)
  std::string auto_surface = "elastic";  // init auto: bim, or bim + elastic refinement
  bool auto_reverse_candidates = true;    // init auto without landmarks: BIMOptions::reverse_candidates
  std::string boundary_stage = "auto";   // Algorithm 1 stage 2: on | off | auto (off from landmarks)
  std::string interior_init = "closest";  // X's interior at the start: closest (Sec. 5.1) | harmonic
  bool strict = false;                // refuse defective boundaries instead of repairing them
  SymmetricVolumeMapOptions opt;      // Eq. 25 weights and stages
  std::vector<int> landmarks_A, landmarks_B;   // init landmarks: vertices of the tet meshes
  BarycentricMap surface_map_AB, surface_map_BA;  // init surface-map
  std::string surface_map_names[2] = {"map_AB", "map_BA"};  // for messages
  TriMesh surface_map_mesh_A, surface_map_mesh_B;  // the surfaces the maps live on (empty: picked
                                                   // by vertex count among boundary / input surfaces)
  std::string surface_map_mesh_names[2] = {"surface-map mesh A", "surface-map mesh B"};  // for messages
};

struct VolumeMapRun {
  SymmetricVolumeMapResult result;
  VolumeMapMetrics m12, m21;          // of X12, X21
  VolumeMapMetrics f12, f21;          // of the maps as the map files hold them (snapped into the target)
  double snap12 = 0, snap21 = 0;      // largest move of an image by that snapping
  std::string init_detail;
  // init auto / surface-map: the surface maps' mean round trip (A -> B -> A, B -> A -> B) over
  // the surface's bounding-box diagonal; -1 for the other inits.
  double init_round_trip_AB = -1, init_round_trip_BA = -1;
  std::vector<std::string> notes;
  // init ball: the ball maps of the chord-split copies (for quality warnings)
  bool used_ball = false;
  TetMesh ball_mesh_A, ball_mesh_B;
  BallParamResult ball_A, ball_B;
  nlohmann::json report;              // parameters, algorithm_stages, energy, metrics, metrics_map_files
  std::string summary;                // one line for the terminal
};

// Throws InputError on bad input (landmark counts, map sizes, non-ball meshes for init ball).
// A and B gain repair notes when their boundaries are repaired for init auto.
VolumeMapRun run_volume_map(VolumeInput& A, VolumeInput& B, const VolumeMapRequest& req,
                            const ProgressCallback& progress = {});

// report.json's metrics of one direction (Table 3).
nlohmann::json volume_metrics_json(const VolumeMapMetrics& m);

// Per tet of `src`, its volume ratio under the positions X (<= 0: inverted; 0 for a
// degenerate rest tet): the volume_ratio field of A_on_B.vtk.
Eigen::VectorXd tet_volume_ratios(const TetMesh& src, const Eigen::MatrixXd& X);

}  // namespace shapemap
