#include "core/gate.h"

#include <algorithm>
#include <cmath>
#include <numeric>
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

namespace {
std::vector<double> ranks(const std::vector<float>& v) {
  std::vector<size_t> idx(v.size());
  std::iota(idx.begin(), idx.end(), size_t{0});
  std::stable_sort(idx.begin(), idx.end(), [&](size_t i, size_t j) { return v[i] < v[j]; });
  std::vector<double> r(v.size());
  for (size_t k = 0; k < idx.size(); ++k) r[idx[k]] = static_cast<double>(k);
  return r;
}
}  // namespace

double spearman(const std::vector<float>& a, const std::vector<float>& b) {
  if (a.size() != b.size() || a.size() < 2) throw Error("spearman: needs two equally long sets of at least two values");
  const std::vector<double> ra = ranks(a), rb = ranks(b);
  const double mean = (static_cast<double>(a.size()) - 1) / 2;
  double num = 0, da = 0, db = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    num += (ra[i] - mean) * (rb[i] - mean);
    da += (ra[i] - mean) * (ra[i] - mean);
    db += (rb[i] - mean) * (rb[i] - mean);
  }
  return num / std::sqrt(da * db);
}

QueryGate::QueryGate(float threshold, int patience) : threshold_(threshold), patience_(patience) {
  if (patience < 1) throw Error("gate: patience K must be >= 1, got " + std::to_string(patience));
}

GateDecision QueryGate::observe(float score) { return record(violates(score, threshold_)); }

GateDecision QueryGate::record(bool violation) {
  GateDecision d;
  d.violation = violation;
  run_ = d.violation ? run_ + 1 : 0;
  d.run = run_;
  d.query = run_ >= patience_;
  return d;
}

}  // namespace dd
