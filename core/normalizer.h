// Per-dimension min-max normalisation to [-1, 1]. A dimension whose range is (nearly) zero maps to 0.
// The normaliser belongs to the policy and is saved in its checkpoint.
//
// Constant dimensions are treated one of two ways. For observations (Constants::kPassThrough) the
// scale stays 1, so a value that differs at run time enters the network unamplified. For actions
// (Constants::kPin) the scale is huge, so whatever the network outputs there unnormalises to the
// constant: a gripper axis that never tilts in the demonstrations never tilts in a rollout.
#pragma once

#include "core/types.h"

namespace dd {

class Normalizer {
 public:
  /// Identity normaliser for `dim` features (scale 1, offset 0).
  explicit Normalizer(int dim = 0);

  enum class Constants { kPassThrough, kPin };
  /// Fits the per-column min and max of `data` (rows x dim). Throws Error on an empty or non-finite input.
  static Normalizer fit(const Mat& data, Constants constants = Constants::kPassThrough);

  /// Builds a normaliser from stored scale and offset (as saved in a checkpoint).
  static Normalizer from_params(Vec scale, Vec offset);

  int dim() const { return static_cast<int>(scale_.size()); }
  const Vec& scale() const { return scale_; }    // y = x * scale + offset (dim)
  const Vec& offset() const { return offset_; }  // (dim)

  /// Raw units -> [-1, 1], row by row (rows x dim).
  Mat normalize(const Mat& x) const;
  /// [-1, 1] -> raw units, row by row (rows x dim).
  Mat unnormalize(const Mat& y) const;

 private:
  Vec scale_;
  Vec offset_;
};

}  // namespace dd
