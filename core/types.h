// Shared numeric types. Matrices are row-major so that a (rows x dim) block maps directly onto a
// contiguous tensor of the same shape.
#pragma once

#include <Eigen/Core>
#include <vector>

namespace dd {

using Vec = Eigen::VectorXf;                                                      // one row of features
using Mat = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;  // rows x features

/// The rows stacked into a (rows.size() x cols) matrix (cols sizes an empty result).
inline Mat stack_rows(const std::vector<Vec>& rows, Eigen::Index cols) {
  Mat m(static_cast<Eigen::Index>(rows.size()), cols);
  for (size_t i = 0; i < rows.size(); ++i) m.row(static_cast<Eigen::Index>(i)) = rows[i].transpose();
  return m;
}

}  // namespace dd
