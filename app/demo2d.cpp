#include "app/demo2d.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numeric>
#include <random>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/text_file.h"
#include "core/chunks.h"
#include "core/config.h"
#include "core/ensemble.h"
#include "core/gate.h"
#include "core/policy.h"
#include "core/progress.h"
#include "core/trainer.h"
#include "envs/nav2d.h"
#include "envs/nav2d_expert.h"
#include "ui/plot.h"

namespace dd::app {
namespace {

namespace fs = std::filesystem;

const char* kRegions[] = {"id_um", "id_mm", "ood"};
const char* kRegionTitles[] = {"ID, UM", "ID, MM", "OOD"};
const ui::Rgb kRegionColors[] = {{235, 120, 50}, {60, 170, 90}, {60, 110, 210}};
const int kAlongSteps[] = {2, 4, 8};  // control steps along the paths from the multi-modal probes' starts

// A set of probe states: a region's, or the multi-modal starts some steps along the expert's paths.
struct ProbeGroup {
  std::string name;     // id_um, id_mm, ood, along_<steps>
  int steps_along = -1; // control steps along the paths from the multi-modal starts (id_mm: 0); -1: not on them
  Mat obs;
  // the group's row title in the along-the-paths tables
  std::string title() const { return steps_along == 0 ? "id_mm (at rest on the start)" : std::to_string(steps_along) + " steps along"; }
};

std::string along_group_name(int steps) { return "along_" + std::to_string(steps); }

// The groups on the paths, in order: the multi-modal start, then each of kAlongSteps.
std::vector<ProbeGroup> path_groups() {
  std::vector<ProbeGroup> g{{"id_mm", 0, {}}};
  for (const int steps : kAlongSteps) g.push_back({along_group_name(steps), steps, {}});
  return g;
}

struct Demos {
  std::vector<Episode> episodes;
  std::vector<std::vector<Vec2>> paths;  // agent positions per episode, for drawing
  std::vector<int> clockwise;            // 1 if the episode went clockwise
  Mat states;                            // all observations (x, y, vx, vy), for nearest-velocity look-ups
};

Demos collect(int n, uint64_t seed) {
  Demos d;
  Nav2dEnv env;
  Nav2dExpert expert(Nav2dExpert::Mode::kMixed);
  int failures = 0;
  std::vector<Vec> rows;
  for (int e = 0; e < n; ++e) {
    const uint64_t s = seed * 100003 + static_cast<uint64_t>(e);
    env.reset(s);
    expert.reset(s);
    std::vector<Vec> obs, act;
    std::vector<Vec2> path{env.position()};
    for (int t = 0; t < env.time_limit(); ++t) {
      obs.push_back(env.observation());
      act.push_back(expert.act(env));
      const StepResult r = env.step(act.back());
      path.push_back(env.position());
      if (r.done) break;
    }
    if (!env.success()) {
      ++failures;
      continue;
    }
    rows.insert(rows.end(), obs.begin(), obs.end());
    d.episodes.push_back(Episode{stack_rows(obs, 4), stack_rows(act, 2)});
    d.paths.push_back(std::move(path));
    d.clockwise.push_back(expert.episode_mode() == Nav2dExpert::Mode::kClockwise);
  }
  if (failures) spdlog::warn("demo2d: {} of {} expert episodes failed and were dropped", failures, n);
  d.states = stack_rows(rows, 4);
  return d;
}

// The velocity of the demonstration state nearest to p: probes off the paths get a plausible
// velocity, so that they differ from the data in position only.
Vec2 nearest_velocity(const Mat& states, const Vec2& p) {
  Eigen::Index best = 0;
  float best_d = INFINITY;
  for (Eigen::Index i = 0; i < states.rows(); ++i) {
    const float dx = states(i, 0) - static_cast<float>(p.x()), dy = states(i, 1) - static_cast<float>(p.y());
    const float d = dx * dx + dy * dy;
    if (d < best_d) {
      best_d = d;
      best = i;
    }
  }
  return {states(best, 2), states(best, 3)};
}

Vec state(const Vec2& p, const Vec2& v) {
  Vec o(4);
  o << static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(v.x()), static_cast<float>(v.y());
  return o;
}

// `runs` probe states per region (rows of obs).
std::array<Mat, 3> probe_states(const Nav2dRegions& regions, const Demos& demos, int runs, uint64_t seed) {
  std::mt19937_64 rng(seed ^ 0x5eed5eedull);
  std::array<std::vector<Vec>, 3> found;
  // Uni-modal: states of fresh expert rollouts that lie along one path, away from the divergence point.
  Nav2dEnv env;
  for (uint64_t e = 0; static_cast<int>(found[0].size()) < runs * 4 && e < 1000; ++e) {
    Nav2dExpert expert(e % 2 ? Nav2dExpert::Mode::kClockwise : Nav2dExpert::Mode::kCounterClockwise);
    env.reset(seed * 7 + 50000 + e);
    for (int t = 0; t < env.time_limit(); ++t) {
      if (regions.label(env.position()) == Nav2dRegion::kUniModal) found[0].push_back(env.observation());
      if (env.step(expert.act(env)).done) break;
    }
  }
  std::shuffle(found[0].begin(), found[0].end(), rng);
  found[0].resize(static_cast<size_t>(runs));
  // Multi-modal: initial states, at rest where the two paths diverge.
  for (int r = 0; r < runs; ++r) {
    env.reset(seed * 7 + 90000 + static_cast<uint64_t>(r));
    found[1].push_back(env.observation());
  }
  // Out of distribution: free positions far from both paths.
  const double h = env.config().arena_half;
  std::uniform_real_distribution<double> u(-h, h);
  while (static_cast<int>(found[2].size()) < runs) {
    const Vec2 p(u(rng), u(rng));
    if (regions.label(p) == Nav2dRegion::kOutOfDistribution) found[2].push_back(state(p, nearest_velocity(demos.states, p)));
  }
  std::array<Mat, 3> out;
  for (int k = 0; k < 3; ++k) out[static_cast<size_t>(k)] = stack_rows(found[static_cast<size_t>(k)], 4);
  return out;
}

// Probes `steps` control steps along the expert's paths from the multi-modal probes' start states
// (the same starts; even probes go clockwise, odd ones counter-clockwise): by then the agent moves
// along one path, so the decision there is no longer between two modes.
Mat along_path_states(int steps, int runs, uint64_t seed) {
  Nav2dEnv env;
  std::vector<Vec> rows;
  for (int r = 0; r < runs; ++r) {
    Nav2dExpert expert(r % 2 == 0 ? Nav2dExpert::Mode::kClockwise : Nav2dExpert::Mode::kCounterClockwise);
    const uint64_t s = seed * 7 + 90000 + static_cast<uint64_t>(r);
    env.reset(s);
    expert.reset(s);
    for (int t = 0; t < steps; ++t) env.step(expert.act(env));
    rows.push_back(env.observation());
  }
  return stack_rows(rows, 4);
}

// The expected diffusion loss of the chunk the policy generates at each observation row.
std::vector<float> decision_losses(const DiffusionPolicy& policy, const Mat& obs, int n_samples, uint64_t seed,
                                   const ProgressFn& progress = {}) {
  const std::vector<Mat> chunks = policy.sample_batch(obs, seed);
  ChunkDataset d;
  d.horizon = policy.config().horizon;
  d.action_dim = policy.config().action_dim;
  d.obs = obs;
  d.chunks.resize(obs.rows(), d.horizon * d.action_dim);
  for (Eigen::Index i = 0; i < obs.rows(); ++i)
    d.chunks.row(i) = Eigen::Map<const Eigen::RowVectorXf>(chunks[static_cast<size_t>(i)].data(), d.horizon * d.action_dim);
  return policy.expected_losses(d, seed + 1, n_samples, progress);
}

std::pair<double, double> mean_std(const std::vector<float>& v) {
  double m = 0, s = 0;
  for (float x : v) m += x;
  m /= std::max<size_t>(1, v.size());
  for (float x : v) s += (x - m) * (x - m);
  return {m, std::sqrt(s / std::max<size_t>(1, v.size()))};
}

double fraction_above(const std::vector<float>& v, float threshold) {
  size_t n = 0;
  for (float x : v) n += x > threshold;
  return v.empty() ? 0.0 : static_cast<double>(n) / v.size();
}

std::vector<ui::Overlay> scene_overlays(const Nav2dConfig& cfg, const Demos& demos) {
  std::vector<ui::Overlay> o;
  for (size_t i = 0; i < demos.paths.size(); ++i) {
    ui::Overlay path;
    path.points = demos.paths[i];
    path.color = demos.clockwise[i] ? ui::Rgb{255, 150, 60} : ui::Rgb{255, 70, 70};
    path.thickness = 1;
    o.push_back(path);
  }
  ui::Overlay obstacle;
  obstacle.radius = cfg.obstacle_radius;
  obstacle.color = {255, 255, 255};
  obstacle.thickness = 2;
  o.push_back(obstacle);
  ui::Overlay start;
  start.center = cfg.start_center;
  start.radius = 0.03;
  start.color = {60, 220, 110};
  start.thickness = -1;
  start.label = "start";
  o.push_back(start);
  ui::Overlay goal;
  goal.center = cfg.goal;
  goal.radius = cfg.goal_radius;
  goal.color = {255, 255, 255};
  goal.thickness = 2;
  goal.label = "goal";
  o.push_back(goal);
  return o;
}

}  // namespace

void Demo2dOptions::apply_quick() {
  quick = true;
  demos = 30;
  train_steps = 250;
  batch_size = 128;
  runs = 20;
  grid = 16;
  loss_samples = 128;
  field_loss_samples = 64;
}

Demo2dResult run_demo2d(const Demo2dOptions& o) {
  const auto t_start = std::chrono::steady_clock::now();
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (ec) throw Error(o.out + ": could not create the output folder: " + ec.message());
  Demo2dResult result;

  // 1. Demonstrations.
  const Demos demos = collect(o.demos, o.seed);
  if (demos.episodes.empty()) throw Error("demo2d: the expert produced no successful demonstration");
  const int cw = static_cast<int>(std::count(demos.clockwise.begin(), demos.clockwise.end(), 1));
  fmt::print(stderr, "[1/5] demonstrations: {} episodes ({} clockwise, {} counter-clockwise), {} steps\n", demos.episodes.size(),
             cw, demos.episodes.size() - static_cast<size_t>(cw), demos.states.rows());

  // 2. One policy and a bootstrapped ensemble, same architecture and budget.
  PolicyConfig pc;
  pc.obs_dim = 4;
  pc.action_dim = 2;
  pc.horizon = 16;
  pc.action_steps = 8;
  pc.unet = unet_preset(o.preset);
  {
    nlohmann::json j = pc.scheduler;
    j["prediction"] = o.prediction;
    pc.scheduler = j.get<SchedulerConfig>();
  }
  TrainConfig tc;
  tc.steps = o.train_steps;
  tc.batch_size = o.batch_size;
  tc.lr = 1e-3;
  tc.warmup_steps = std::min(100, o.train_steps / 10);
  tc.seed = o.seed;
  const ChunkDataset data = ChunkDataset::from_episodes(demos.episodes, pc.horizon);
  PolicyEnsemble ensemble(pc, o.members, o.seed + 101);
  {
    ProgressBar bar(fmt::format("[2/5] train ensemble ({})", o.members), "loss");
    ensemble.train(demos.episodes, tc, bar.fn());
  }
  // Diff-DAgger's policy is the member trained on all the demonstrations, as in eval's RQ1: both
  // rules judge the same network's decisions, and the demo trains five policies instead of six.
  DiffusionPolicy& policy = ensemble.member(0);

  // 3. Thresholds at alpha over (a subset of) the training pairs, as the query rules would set them.
  const ChunkDataset cal = data.subset(o.quick ? 200 : 1000, o.seed + 7);
  const int n_cal = cal.size();
  float loss_threshold = 0, std_threshold = 0;
  {
    ProgressBar bar("[3/5] calibrate thresholds", "loss");
    // screened, as Diff-DAgger's own update sets it (the pairs far below the quantile keep a cheap estimate)
    loss_threshold = policy.loss_quantile(cal, o.alpha, o.seed + 11, o.loss_samples, /*screen=*/true, bar.fn()).threshold;
  }
  std_threshold = quantile(ensemble.action_std(cal.obs, o.seed + 13), o.alpha);

  // 4. Probes per region.
  const Nav2dRegions regions;
  const std::array<Mat, 3> probes = probe_states(regions, demos, o.runs, o.seed);
  std::map<std::string, std::vector<float>> values;  // "region/metric" -> per-run values
  for (int k = 0; k < 3; ++k) {
    values[std::string(kRegions[k]) + "/ensemble_std"] = ensemble.action_std(probes[static_cast<size_t>(k)], o.seed + 200 + static_cast<uint64_t>(k));
  }
  // The multi-modal probes' starts, a few steps along each path: does the verdict hang on one point?
  std::vector<ProbeGroup> groups;  // every probe group: the three regions, then along the paths
  for (int k = 0; k < 3; ++k) groups.push_back({kRegions[k], k == 1 ? 0 : -1, probes[static_cast<size_t>(k)]});
  for (const int steps : kAlongSteps) {
    groups.push_back({along_group_name(steps), steps, along_path_states(steps, o.runs, o.seed)});
    values[groups.back().name + "/ensemble_std"] =
        ensemble.action_std(groups.back().obs, o.seed + 200 + static_cast<uint64_t>(groups.size() - 1));
  }
  fmt::print(stderr, "[4/5] probed {} states in each of the regions id_um, id_mm, ood and {} steps along the paths\n", o.runs,
             fmt::join(kAlongSteps, ", "));

  // The same probes' loss split by diffusion timestep, in each space the loss can be scored in (the
  // targets convert into one another): where along t do the regions separate, and which score keeps
  // in-distribution multi-modal states low? Same chunks and noise seeds as the region probes.
  const ScoreSpace kSpaces[] = {ScoreSpace::kTarget, ScoreSpace::kEpsilon, ScoreSpace::kVelocity, ScoreSpace::kSample};
  const int T_d = pc.scheduler.num_train_timesteps;
  auto is_training_target = [&](ScoreSpace space) {
    const PredictionType p = pc.scheduler.prediction;
    return (space == ScoreSpace::kEpsilon && p == PredictionType::kEpsilon) || (space == ScoreSpace::kSample && p == PredictionType::kSample) ||
           (space == ScoreSpace::kVelocity && p == PredictionType::kVelocity);
  };
  const int n_t = std::max(1, o.loss_samples / T_d) * T_d;
  std::map<std::string, std::vector<std::vector<float>>> by_t;  // "space/region" -> per probe, T_d losses
  for (size_t k = 0; k < groups.size(); ++k) {
    const Mat& obs = groups[k].obs;
    const std::vector<Mat> chunks = policy.sample_batch(obs, o.seed + 300 + static_cast<uint64_t>(k));
    const std::vector<ScoreSpace> spaces(std::begin(kSpaces), std::end(kSpaces));
    for (Eigen::Index i = 0; i < obs.rows(); ++i) {
      const std::vector<std::vector<float>> l = policy.loss_by_timestep(
          obs.row(i).transpose(), chunks[static_cast<size_t>(i)], o.seed + 600 + static_cast<uint64_t>(k) * 100000 + static_cast<uint64_t>(i),
          n_t, spaces);
      for (size_t j = 0; j < spaces.size(); ++j) by_t[to_string(spaces[j]) + "/" + groups[k].name].push_back(l[j]);
    }
  }
  // per space and region: the mean over probes at each t, and each probe's mean over t (the score)
  auto mean_over_probes = [&](const std::string& key, int t) {
    double m = 0;
    for (const auto& row : by_t[key]) m += row[static_cast<size_t>(t)];
    return m / static_cast<double>(by_t[key].size());
  };
  auto scores_of = [&](const std::string& key) {
    std::vector<float> v;
    for (const auto& row : by_t[key]) v.push_back(std::accumulate(row.begin(), row.end(), 0.0f) / static_cast<float>(row.size()));
    return v;
  };
  // The same score drawing t from the lowest-noise quarter only (method.score_timesteps = T_d / 4).
  const int low_k = std::max(1, T_d / 4);
  auto low_scores_of = [&](const std::string& key) {
    std::vector<float> v;
    for (const auto& row : by_t[key]) v.push_back(std::accumulate(row.begin(), row.begin() + low_k, 0.0f) / static_cast<float>(low_k));
    return v;
  };
  // Every score the summaries compare: each space, over all timesteps and over the low-noise ones.
  struct Score {
    std::string name;   // measure name after "loss_": epsilon, v, sample, epsilon_low, ...
    std::string title;  // for tables
    ScoreSpace space;
    bool low;
  };
  std::vector<Score> scores;
  for (const bool low : {false, true})
    for (const ScoreSpace space : kSpaces)
      if (space != ScoreSpace::kTarget)
        scores.push_back({to_string(space) + (low ? "_low" : ""),
                          to_string(space) + (low ? fmt::format(", t < {}", low_k) : std::string()), space, low});
  auto score_values = [&](const Score& sc, const std::string& group) {
    return sc.low ? low_scores_of(to_string(sc.space) + "/" + group) : scores_of(to_string(sc.space) + "/" + group);
  };
  // The paper's score (the training target's space) of the chunk generated at each region's probes.
  for (const char* region : kRegions) values[std::string(region) + "/diffusion_loss"] = scores_of(std::string("target/") + region);

  // Every group's mean ensemble std and mean score in each space, for the summaries over seeds.
  for (const ProbeGroup& g : groups) {
    const std::string& group = g.name;
    result.means["ensemble_std/" + group] = mean_std(values[group + "/ensemble_std"]).first;
    for (const ScoreSpace space : kSpaces)
      result.means["loss_" + to_string(space) + "/" + group] = mean_std(scores_of(to_string(space) + "/" + group)).first;
    for (const Score& sc : scores)
      if (sc.low) result.means["loss_" + sc.name + "/" + group] = mean_std(score_values(sc, group)).first;
  }
  {  // along the paths: each group's numbers, the multi-modal start being 0 steps along
    std::string along = "group,steps_along,measure,mean,std,n\n";
    for (const ProbeGroup& g : groups) {
      const std::string& group = g.name;
      const std::string steps = g.steps_along >= 0 ? std::to_string(g.steps_along) : "";
      const auto [em, es] = mean_std(values[group + "/ensemble_std"]);
      along += fmt::format("{},{},ensemble_std,{:.9g},{:.6g},{}\n", group, steps, em, es, g.obs.rows());
      for (const Score& sc : scores) {
        const auto [lm, ls] = mean_std(score_values(sc, group));
        along += fmt::format("{},{},loss_{},{:.9g},{:.6g},{}\n", group, steps, sc.name, lm, ls, g.obs.rows());
      }
    }
    const std::string along_path = o.out + "/fig2_along_paths.csv";
    write_text(along_path, along);
    result.files.push_back(along_path);
  }

  std::string csv = "region,metric,mean,std,n\n";
  for (const char* metric : {"ensemble_std", "diffusion_loss"}) {
    for (const char* region : kRegions) {
      const auto [m, s] = mean_std(values[std::string(region) + "/" + metric]);
      result.stats.push_back({region, metric, m, s, o.runs});
      csv += fmt::format("{},{},{:.6g},{:.6g},{}\n", region, metric, m, s, o.runs);
    }
  }
  auto stat = [&](const std::string& region, const std::string& metric) -> double {
    for (const auto& s : result.stats)
      if (s.region == region && s.metric == metric) return s.mean;
    return NAN;
  };

  // 5. Fields over the plane, then the files.
  const Nav2dConfig nav;
  const int G = o.grid;
  Mat loss_field = Mat::Constant(G, G, NAN), std_field = Mat::Constant(G, G, NAN);
  std::vector<std::pair<int, int>> cells;
  std::vector<Vec> cell_obs;
  Nav2dEnv probe_env;
  for (int r = 0; r < G; ++r) {
    for (int c = 0; c < G; ++c) {
      const Vec2 p(-nav.arena_half + (c + 0.5) * 2 * nav.arena_half / G, -nav.arena_half + (r + 0.5) * 2 * nav.arena_half / G);
      if (!probe_env.is_free(p)) continue;
      cells.emplace_back(r, c);
      cell_obs.push_back(state(p, nearest_velocity(demos.states, p)));
    }
  }
  const Mat field_obs = stack_rows(cell_obs, 4);
  std::vector<float> field_loss;
  {
    ProgressBar bar("[5/5] loss field", "loss");
    field_loss = decision_losses(policy, field_obs, o.field_loss_samples, o.seed + 400, bar.fn());
  }
  const std::vector<float> field_std = ensemble.action_std(field_obs, o.seed + 500);
  for (size_t i = 0; i < cells.size(); ++i) {
    loss_field(cells[i].first, cells[i].second) = field_loss[i];
    std_field(cells[i].first, cells[i].second) = field_std[i];
  }

  const std::string csv_path = o.out + "/fig2_regions.csv";
  write_text(csv_path, csv);
  result.files.push_back(csv_path);

  {  // the loss by timestep: CSV and one panel per space
    std::string t_csv = "space,region,t,mean_loss\n";
    std::vector<ui::Image> panels;
    for (const ScoreSpace space : kSpaces) {
      if (space == ScoreSpace::kTarget) continue;  // the same numbers as the training target's own space
      ui::LinePanel p;
      p.title = fmt::format("scored in {} space{}", to_string(space),
                            is_training_target(space) ? " (the training target)" : "");
      p.x_label = "diffusion timestep t (higher: noisier)";
      p.y_label = "mean loss over probes";
      p.width = 460;
      p.y_min = 0;
      for (int k = 0; k < 3; ++k) {
        const std::string key = to_string(space) + "/" + kRegions[k];
        ui::LineSeries line;
        line.name = kRegions[k];
        line.color = kRegionColors[k];  // the bar plot's colours
        for (int t = 0; t < T_d; ++t) {
          line.x.push_back(t);
          line.y.push_back(mean_over_probes(key, t));
          t_csv += fmt::format("{},{},{},{:.6g}\n", to_string(space), kRegions[k], t, line.y.back());
        }
        p.series.push_back(std::move(line));
      }
      panels.push_back(ui::draw_lines(p));
    }
    const std::string t_csv_path = o.out + "/fig2_loss_by_timestep.csv", t_png_path = o.out + "/fig2_loss_by_timestep.png";
    write_text(t_csv_path, t_csv);
    ui::write_png(t_png_path, ui::hstack(panels, fmt::format("one network ({} objective) scored in each space; {} probes per region, "
                                                             "{} rows per timestep each",
                                                             to_string(pc.scheduler.prediction), o.runs, n_t / T_d)));
    result.files.push_back(t_csv_path);
    result.files.push_back(t_png_path);
  }

  std::vector<ui::Image> bars;
  for (const auto& [metric, title, label] :
       {std::tuple<std::string, std::string, std::string>{"ensemble_std", "Ensemble: action std", "action std across 5 policies [m]"},
        {"diffusion_loss", "Diff-DAgger: diffusion loss", "expected diffusion loss (normalised units)"}}) {
    ui::BarPanel p;
    p.title = title;
    p.y_label = label;
    for (int k = 0; k < 3; ++k) {
      for (const auto& s : result.stats) {
        if (s.region == kRegions[k] && s.metric == metric) {
          p.values.push_back(s.mean);
          p.errors.push_back(s.std);
        }
      }
      p.categories.push_back(kRegionTitles[k]);
      p.colors.push_back(kRegionColors[k]);
    }
    bars.push_back(ui::draw_bars(p));
  }
  const std::string bars_path = o.out + "/fig2_regions.png";
  ui::write_png(bars_path, ui::hstack(bars, fmt::format("mean +- std over {} runs per region; {} demonstrations, {} training steps per policy", o.runs,
                                                        demos.episodes.size(), o.train_steps)));
  result.files.push_back(bars_path);

  std::vector<ui::Image> fields;
  for (int k = 0; k < 2; ++k) {
    ui::FieldPanel f;
    f.title = k == 0 ? "Diffusion loss of the generated chunk" : "Ensemble action std";
    f.colorbar_label = k == 0 ? "expected diffusion loss" : "action std [m]";
    f.values = k == 0 ? loss_field : std_field;
    f.x0 = f.y0 = -nav.arena_half;
    f.x1 = f.y1 = nav.arena_half;
    f.log_scale = true;
    f.overlays = scene_overlays(nav, demos);
    fields.push_back(ui::draw_field(f));
  }
  const std::string field_path = o.out + "/loss_field.png";
  ui::write_png(field_path, ui::hstack(fields, "x, y in [m]; demonstrations: orange clockwise, red counter-clockwise; velocity taken from the nearest demonstration state; grey: obstacle"));
  result.files.push_back(field_path);

  // The paper's claim: the ensemble spread is high at the multi-modal point, the diffusion loss only
  // out of distribution.
  const double e_um = stat("id_um", "ensemble_std"), e_mm = stat("id_mm", "ensemble_std"), e_ood = stat("ood", "ensemble_std");
  const double d_um = stat("id_um", "diffusion_loss"), d_mm = stat("id_mm", "diffusion_loss"), d_ood = stat("ood", "diffusion_loss");
  // The claim's numbers, the same bars as every score's row below: at least 2x and at least 3x.
  const bool ensemble_confused = e_mm >= 2 * e_um;
  const bool loss_separates = d_ood >= 3 * d_mm && d_ood > d_um;
  result.claim_holds = ensemble_confused && loss_separates;
  std::map<std::string, double> flag_loss, flag_std;
  for (const char* r : kRegions) {
    flag_loss[r] = fraction_above(values[std::string(r) + "/diffusion_loss"], loss_threshold);
    flag_std[r] = fraction_above(values[std::string(r) + "/ensemble_std"], std_threshold);
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  std::string md = fmt::format(
      "# 2-D multimodality demo (figure 2)\n\n"
      "{} expert demonstrations ({} clockwise, {} counter-clockwise); a {}-member bootstrapped ensemble of diffusion policies "
      "(U-Net down_dims {}, {} objective), {} training steps each at batch {}, whose member 0, trained on all the "
      "demonstrations, is Diff-DAgger's policy; {} probe states per region; N_b = {}.{}\n\n"
      "## The claim\n\n"
      "The paper: an ensemble's action spread is high at an in-distribution multi-modal point, where its members disagree on "
      "the mode, while the diffusion loss is high only out of distribution.\n\n"
      "**On this run the claim {}.**\n\n"
      "- Ensemble std at the multi-modal point is **{:.2f}x** its value along the paths (id_mm / id_um) and {:.2f}x the "
      "out-of-distribution value (id_mm / ood){}.\n"
      "- Diffusion loss out of distribution is **{:.2f}x** its value along the paths (ood / id_um) and **{:.2f}x** its value at the "
      "multi-modal point (ood / id_mm); at the multi-modal point it is {:.2f}x the path value{}.\n\n"
      "## Per region (mean +- std over runs)\n\n"
      "| region | ensemble std [m] | diffusion loss | ensemble flags at alpha {} | diffusion loss flags at alpha {} |\n"
      "|---|---|---|---|---|\n",
      demos.episodes.size(), cw, demos.episodes.size() - static_cast<size_t>(cw), o.members,
      fmt::join(pc.unet.down_dims, ","), to_string(pc.scheduler.prediction), o.train_steps, o.batch_size, o.runs, o.loss_samples,
      o.quick ? " (quick run: reduced sizes, read with care)" : "",
      result.claim_holds ? "holds" : "does not hold", e_mm / e_um, e_mm / e_ood,
      ensemble_confused ? "" : " (the ensemble is *not* 2x more spread at the multi-modal point here)", d_ood / d_um, d_ood / d_mm,
      d_mm / d_um, loss_separates ? "" : " (the loss does *not* single out the OOD region 3x here)", o.alpha, o.alpha);
  for (int k = 0; k < 3; ++k) {
    const std::string r = kRegions[k];
    const auto es = mean_std(values[r + "/ensemble_std"]);
    const auto ds = mean_std(values[r + "/diffusion_loss"]);
    md += fmt::format("| {} | {:.4f} +- {:.4f} | {:.4f} +- {:.4f} | {:.0f}% | {:.0f}% |\n", r, es.first, es.second, ds.first, ds.second,
                      100 * flag_std[r], 100 * flag_loss[r]);
  }
  if (d_mm > 2 * d_um) {
    md += "\n**Why the loss is high at the divergence point too.** There, at rest on the start, the chunk's conditional "
          "distribution really is bimodal. At high noise the denoiser can only predict the mean of the two modes, so under the "
          "v and sample objectives the high-noise terms of the expected loss cost about the spread between the modes, whichever "
          "mode the chunk follows. The paper's patience K guards against this: the next decision, T_a steps later, is already "
          "on one path and scores low, so with K = 2 a single high decision at the start does not raise a query. "
          "Try `--prediction epsilon` to compare objectives.\n";
  }
  md += fmt::format("\n## The same network scored in each space\n\n"
                    "The three targets are conversions of one another, so the {} network's loss can be measured in any: per "
                    "timestep the epsilon-space loss weights the v-space loss by alpha_bar_t (low at high noise), the sample-space "
                    "loss by 1 - alpha_bar_t. `fig2_loss_by_timestep.png` shows each region's loss against t. The rows "
                    "\"t < {}\" are the same scores drawing t from the lowest-noise quarter only (`method.score_timesteps: {}`).\n\n"
                    "The last column applies the claim's numbers to each score: the ensemble's id_mm / id_um at least 2 (here "
                    "{:.2f}x) and the loss's ood / id_mm at least 3.\n\n"
                    "| space | id_um | id_mm | ood | ood / id_mm | ood / id_um | claim |\n|---|---|---|---|---|---|---|\n",
                    to_string(pc.scheduler.prediction), low_k, low_k, e_mm / e_um);
  std::string per_space;
  for (const Score& sc : scores) {
    double m[3];
    for (int k = 0; k < 3; ++k) m[k] = mean_std(score_values(sc, kRegions[k])).first;
    const bool holds = e_mm / e_um >= 2 && m[2] / m[1] >= 3;
    md += fmt::format("| {}{} | {:.4g} | {:.4g} | {:.4g} | {:.2f}x | {:.2f}x | {} |\n", sc.title,
                      is_training_target(sc.space) && !sc.low ? " (training target)" : "", m[0], m[1], m[2], m[2] / m[1],
                      m[2] / m[0], holds ? "holds" : "does not hold");
    per_space += fmt::format("  scored in {:14} loss ood/id_mm = {:5.2f}x: claim {}\n", sc.title, m[2] / m[1],
                             holds ? "holds" : "does not hold");
  }
  {
    md += fmt::format("\n## Along the paths\n\n"
                      "The multi-modal probes sit at rest on the start. The same starts, a few control steps along the expert's "
                      "path (half clockwise, half counter-clockwise): the ensemble's spread over its value along the paths "
                      "(claim: at least 2 at a multi-modal point), and out-of-distribution loss over the loss there, in each "
                      "space (claim: at least 3). `fig2_along_paths.csv` has the numbers.\n\n"
                      "| probes | ensemble / id_um |");
    std::vector<ScoreSpace> shown;
    for (const ScoreSpace space : kSpaces)
      if (space != ScoreSpace::kTarget) shown.push_back(space);
    for (const ScoreSpace space : shown) md += fmt::format(" ood / here, {} |", to_string(space));
    md += "\n|---|---|";
    for (size_t i = 0; i < shown.size(); ++i) md += "---|";
    md += "\n";
    for (const ProbeGroup& g : groups) {
      if (g.steps_along < 0) continue;
      const std::string& group = g.name;
      md += fmt::format("| {} | {:.2f}x |", g.title(), result.means["ensemble_std/" + group] / result.means["ensemble_std/id_um"]);
      for (const ScoreSpace space : shown) {
        const std::string m = "loss_" + to_string(space) + "/";
        md += fmt::format(" {:.2f}x |", result.means[m + "ood"] / result.means[m + group]);
      }
      md += "\n";
    }
  }
  md += fmt::format(
      "\nThresholds are the alpha-quantile over {} training pairs: ensemble std {:.4f} m, diffusion loss {:.4f}. "
      "A \"flag\" is one decision above the threshold (K = 1).\n\n"
      "Files: `fig2_regions.csv`, `fig2_regions.png` (figure 2b), `loss_field.png` (both measures over the plane), "
      "`fig2_loss_by_timestep.csv` and `.png` (the probes' loss by timestep in each space), `fig2_along_paths.csv`. "
      "Took {}.\n",
      n_cal, std_threshold, loss_threshold, format_duration(seconds));
  const std::string md_path = o.out + "/summary.md";
  write_text(md_path, md);
  result.files.push_back(md_path);

  fmt::print("\n{:8} {:>16} {:>16}\n", "region", "ensemble std [m]", "diffusion loss");
  for (int k = 0; k < 3; ++k)
    fmt::print("{:8} {:>16.4f} {:>16.4f}\n", kRegions[k], stat(kRegions[k], "ensemble_std"), stat(kRegions[k], "diffusion_loss"));
  fmt::print("\nclaim {}: ensemble id_mm/id_um = {:.2f}x; diffusion loss ood/id_um = {:.2f}x, ood/id_mm = {:.2f}x\n",
             result.claim_holds ? "holds" : "does not hold", e_mm / e_um, d_ood / d_um, d_ood / d_mm);
  fmt::print("the same network's loss in each space (claim: ensemble id_mm/id_um >= 2 and loss ood/id_mm >= 3):\n{}", per_space);
  fmt::print("wrote {} files to {} in {}\n", result.files.size(), o.out, format_duration(seconds));
  return result;
}

Demo2dResult read_demo2d_means(const std::string& path) {
  Demo2dResult r;
  std::istringstream rows(read_text(path));
  std::string line;
  std::getline(rows, line);
  if (line != "group,steps_along,measure,mean,std,n") throw Error(path + ": not a fig2_along_paths.csv (its header is '" + line + "')");
  for (int row = 2; std::getline(rows, line); ++row) {
    std::vector<std::string> f;
    std::istringstream fields(line);
    for (std::string x; std::getline(fields, x, ',');) f.push_back(x);
    try {
      if (f.size() != 6) throw std::invalid_argument("6 fields expected");
      r.means[f[2] + "/" + f[0]] = std::stod(f[3]);
    } catch (const std::exception& e) {
      throw Error(fmt::format("{} line {}: malformed row '{}' ({})", path, row, line, e.what()));
    }
  }
  return r;
}

std::vector<Demo2dResult> run_demo2d_seeds(const Demo2dOptions& o) {
  if (o.seeds <= 1) return {run_demo2d(o)};
  std::vector<Demo2dResult> runs;
  std::vector<uint64_t> seeds;
  for (int i = 0; i < o.seeds; ++i) {
    Demo2dOptions one = o;
    one.seed = o.seed + static_cast<uint64_t>(i);
    one.out = o.out + "/seed_" + std::to_string(one.seed);
    seeds.push_back(one.seed);
    // a seed finished by an earlier run (its summary.md is written last) is read back, not run again
    if (fs::exists(one.out + "/summary.md") && fs::exists(one.out + "/fig2_along_paths.csv")) {
      runs.push_back(read_demo2d_means(one.out + "/fig2_along_paths.csv"));
      fmt::print(stderr, "=== seed {} ({} of {}): finished earlier, read from {}\n", one.seed, i + 1, o.seeds, one.out);
      continue;
    }
    fmt::print(stderr, "=== seed {} ({} of {}) into {}\n", one.seed, i + 1, o.seeds, one.out);
    runs.push_back(run_demo2d(one));
  }
  // Per seed and score: the claim's two ratios and whether it holds there.
  auto ratio = [](const Demo2dResult& r, const std::string& num, const std::string& den) {
    return r.means.at(num) / r.means.at(den);
  };
  const std::string prediction = o.prediction == "v_prediction" ? "v" : o.prediction;
  std::string csv = "seed,space,ensemble_mm_over_um,loss_ood_over_mm,loss_ood_over_um,claim\n";
  std::string md = fmt::format(
      "# 2-D multimodality demo (figure 2) over {} seeds\n\n"
      "Seeds {}, each a full run in `seed_<s>/` ({} objective). The claim: the ensemble's spread at the in-distribution "
      "multi-modal point is at least 2x its value along the paths (id_mm / id_um), and the policy's loss out of "
      "distribution at least 3x its value at the multi-modal point (ood / id_mm). The same network's loss is scored in each "
      "space.\n\n| score | ensemble id_mm / id_um | loss ood / id_mm | loss ood / id_um | claim holds in |\n|---|---|---|---|---|\n",
      o.seeds, fmt::join(seeds, ", "), o.prediction);
  auto mean_sd = [](const std::vector<double>& v) {
    double m = 0, s = 0;
    for (double x : v) m += x;
    m /= static_cast<double>(v.size());
    for (double x : v) s += (x - m) * (x - m);
    return fmt::format("{:.2f} +- {:.2f}", m, std::sqrt(s / static_cast<double>(v.size())));
  };
  std::string printed;
  for (const std::string space : {"epsilon", "v", "sample", "epsilon_low", "v_low", "sample_low"}) {
    // (seeds run before the low-noise scores existed have none: those rows are left out)
    if (std::any_of(runs.begin(), runs.end(), [&](const Demo2dResult& r) { return !r.means.count("loss_" + space + "/ood"); })) continue;
    std::vector<double> ens, ood_mm, ood_um;
    int holds = 0;
    for (size_t i = 0; i < runs.size(); ++i) {
      const std::string m = "loss_" + space + "/";
      ens.push_back(ratio(runs[i], "ensemble_std/id_mm", "ensemble_std/id_um"));
      ood_mm.push_back(ratio(runs[i], m + "ood", m + "id_mm"));
      ood_um.push_back(ratio(runs[i], m + "ood", m + "id_um"));
      const bool h = ens.back() >= 2 && ood_mm.back() >= 3;
      holds += h;
      csv += fmt::format("{},{},{:.4f},{:.4f},{:.4f},{}\n", seeds[i], space, ens.back(), ood_mm.back(), ood_um.back(),
                         h ? "holds" : "does not hold");
    }
    const bool low = space.size() > 4 && space.compare(space.size() - 4, 4, "_low") == 0;
    const std::string title = space == prediction ? space + " (the training target: the paper's score)"
                              : low ? space.substr(0, space.size() - 4) + ", low-noise quarter of t"
                                    : space;
    md += fmt::format("| {} | {} | {} | {} | {} of {} seeds |\n", title, mean_sd(ens), mean_sd(ood_mm), mean_sd(ood_um), holds,
                      runs.size());
    printed += fmt::format("  scored in {:12} loss ood/id_mm = {}: claim holds in {} of {} seeds\n", space, mean_sd(ood_mm), holds,
                           runs.size());
  }
  md += "\nMean +- std over seeds. Per seed: `fig2_seeds.csv`.\n\n## Along the paths\n\n"
        "The multi-modal probes' starts, a few control steps along the expert's path: the ensemble's spread over its value "
        "along the paths, and the out-of-distribution loss over the loss there, per space (mean +- std over seeds).\n\n"
        "| probes | ensemble / id_um | ood / here, epsilon | ood / here, v | ood / here, sample |\n|---|---|---|---|---|\n";
  for (const ProbeGroup& pg : path_groups()) {
    const std::string& g = pg.name;
    std::vector<double> ens;
    for (const auto& r : runs) ens.push_back(ratio(r, "ensemble_std/" + g, "ensemble_std/id_um"));
    md += fmt::format("| {} | {} |", pg.title(), mean_sd(ens));
    for (const std::string space : {"epsilon", "v", "sample"}) {
      std::vector<double> v;
      for (const auto& r : runs) v.push_back(ratio(r, "loss_" + space + "/ood", "loss_" + space + "/" + g));
      md += " " + mean_sd(v) + " |";
    }
    md += "\n";
  }
  write_text(o.out + "/fig2_seeds.csv", csv);
  write_text(o.out + "/summary.md", md);
  fmt::print("\nover {} seeds (claim: ensemble id_mm/id_um >= 2 and loss ood/id_mm >= 3):\n{}wrote {}/summary.md and "
             "{}/fig2_seeds.csv\n",
             runs.size(), printed, o.out, o.out);
  return runs;
}

}  // namespace dd::app
