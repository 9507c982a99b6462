// What the experiment files share, internal to app/experiments/: folders, means, resume points.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/task_config.h"

namespace dd::app {

namespace fs = std::filesystem;

/// Creates `dir` and its parents; throws Error naming it when it cannot.
void make_dirs(const std::string& dir);
/// Mean and sample standard deviation (n - 1; 0 for one value); NaN for an empty set.
std::pair<double, double> mean_std(const std::vector<double>& v);
double mean(const std::vector<double>& v);
/// Two-sided Fisher exact test of a 2x2 table (rows: the rule asked / did not ask; columns: the
/// rollout failed / succeeded): the probability, with the margins fixed, of a table no more likely
/// than this one. Written from the hypergeometric law with lgamma (no statistics library is packaged).
double fisher_exact_p(long asked_failed, long asked_succeeded, long quiet_failed, long quiet_succeeded);
/// One stratum (a seed) of a pooled test: the counts in fisher_exact_p's order.
struct AskFailTable {
  long asked_failed = 0, asked_succeeded = 0, quiet_failed = 0, quiet_succeeded = 0;
};
/// Cochran-Mantel-Haenszel test of asking against failing within strata (seeds), two-sided, with
/// the continuity correction, its statistic referred to chi-square with one degree of freedom. Unlike
/// fisher_exact_p on summed counts, seeds whose policies fail at different rates cannot make an
/// association that no seed has. 1 where no stratum has variance (a rule that never or always asks).
/// Hand-written from the statistic's formula, like fisher_exact_p.
double mantel_haenszel_p(const std::vector<AskFailTable>& strata);
/// The resume point a stopped run left in `out` (the JSON file `marker`, with the integer fields
/// `required`), or null when there is none. A point left by a run with another config is refused.
nlohmann::json read_resume_point(const std::string& out, const std::string& marker, const ExperimentConfig& config,
                                 const std::vector<std::string>& required);

}  // namespace dd::app
