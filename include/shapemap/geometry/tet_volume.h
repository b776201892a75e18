// Signed volume of one tet (a, b, c, d): positive when (b - a, c - a, d - a) is a
// right-handed frame. The one formula every stage uses (mesh checks, Laplacians, masses,
// fold counts, untangling), so that "inverted" means the same everywhere.
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace shapemap {

// Six times the signed volume, (b - a) . ((c - a) x (d - a)).
inline double signed_tet_volume6(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                 const Eigen::Vector3d& c, const Eigen::Vector3d& d) {
  return (b - a).dot((c - a).cross(d - a));
}

inline double signed_tet_volume(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                const Eigen::Vector3d& c, const Eigen::Vector3d& d) {
  return signed_tet_volume6(a, b, c, d) / 6.0;
}

}  // namespace shapemap
