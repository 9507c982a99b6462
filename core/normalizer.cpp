#include "core/normalizer.h"

#include "core/config.h"

namespace dd {

// Below this range a dimension counts as constant and maps to 0 instead of being blown up.
constexpr float kRangeEps = 1e-4f;

Normalizer::Normalizer(int dim) : scale_(Vec::Ones(dim)), offset_(Vec::Zero(dim)) {}

Normalizer Normalizer::fit(const Mat& data, Constants constants) {
  if (data.rows() == 0) throw Error("normalizer: cannot fit on an empty data set");
  if (!data.allFinite()) throw Error("normalizer: data contains NaN or infinite values");
  const Vec lo = data.colwise().minCoeff().transpose();
  const Vec hi = data.colwise().maxCoeff().transpose();
  Normalizer n(static_cast<int>(data.cols()));
  for (int i = 0; i < n.dim(); ++i) {
    const float range = hi[i] - lo[i];
    if (range < kRangeEps && constants == Constants::kPin) {
      n.scale_[i] = 2.0f / kRangeEps;  // [-1, 1] unnormalises to within kRangeEps / 2 of the constant
      n.offset_[i] = -n.scale_[i] * 0.5f * (lo[i] + hi[i]);
    } else if (range < kRangeEps) {
      n.scale_[i] = 1.0f;
      n.offset_[i] = -lo[i];  // the constant value maps to 0
    } else {
      n.scale_[i] = 2.0f / range;
      n.offset_[i] = -1.0f - n.scale_[i] * lo[i];
    }
  }
  return n;
}

Normalizer Normalizer::from_params(Vec scale, Vec offset) {
  if (scale.size() != offset.size()) throw Error("normalizer: scale and offset sizes differ");
  Normalizer n;
  n.scale_ = std::move(scale);
  n.offset_ = std::move(offset);
  return n;
}

Mat Normalizer::normalize(const Mat& x) const {
  return (x.array().rowwise() * scale_.transpose().array()).rowwise() + offset_.transpose().array();
}

Mat Normalizer::unnormalize(const Mat& y) const {
  return (y.array().rowwise() - offset_.transpose().array()).rowwise() / scale_.transpose().array();
}

}  // namespace dd
