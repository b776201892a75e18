// Farthest-point sampling.
#pragma once
#include <Eigen/Core>
#include <vector>

namespace shapemap {
class HeatGeodesics;

// k samples by farthest-point sampling of geodesic distance (heat method), starting
// from `first` (or, if first < 0, from the vertex farthest from vertex 0).
std::vector<int> farthest_point_sampling(const HeatGeodesics& geo, int k, int first = -1);

// The same with Dijkstra distances along mesh edges (cheaper, for dense sampling).
std::vector<int> farthest_point_sampling_graph(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                               int k, int first = -1);

}  // namespace shapemap
