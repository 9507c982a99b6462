#include "core/gate.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/config.h"

namespace dd {

float quantile(std::vector<float> values, double alpha) {
  if (values.empty()) throw Error("quantile: no values");
  if (!(alpha >= 0.0 && alpha <= 1.0)) throw Error("quantile: alpha must be in [0, 1]");
  for (float v : values)
    if (!std::isfinite(v)) throw Error("quantile: a calibration value is not finite");
  const size_t n = values.size();
  const size_t k = std::min(n - 1, static_cast<size_t>(std::floor(n * alpha)));
  std::nth_element(values.begin(), values.begin() + static_cast<long>(k), values.end());
  return values[k];
}

QueryGate::QueryGate(float threshold, int patience) : threshold_(threshold), patience_(patience) {
  if (patience < 1) throw Error("gate: patience K must be >= 1, got " + std::to_string(patience));
}

GateDecision QueryGate::observe(float score) { return record(!std::isfinite(score) || score > threshold_); }

GateDecision QueryGate::record(bool violation) {
  GateDecision d;
  d.violation = violation;
  run_ = d.violation ? run_ + 1 : 0;
  d.run = run_;
  d.query = run_ >= patience_;
  return d;
}

}  // namespace dd
