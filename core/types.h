// Shared numeric types. Matrices are row-major so that a (rows x dim) block maps directly onto a
// contiguous tensor of the same shape.
#pragma once

#include <Eigen/Core>

namespace dd {

using Vec = Eigen::VectorXf;                                                      // one row of features
using Mat = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;  // rows x features

}  // namespace dd
