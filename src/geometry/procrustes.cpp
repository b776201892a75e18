#include "shapemap/geometry/procrustes.h"

#include "shapemap/geometry/svd3.h"

namespace shapemap {

Eigen::Matrix3d procrustes_rotation(const Eigen::Matrix3d& C) {
  // With U, V proper rotations the sign of det C sits on the smallest singular value, and
  // U V^T is the best proper rotation (the best orthogonal one would flip that axis).
  const SignedSVD3 svd = signed_svd3(C);
  return svd.U * svd.V.transpose();
}

}  // namespace shapemap
