// `diffdagger plot DIR`: the paper's figure 4 (wall-clock per DAgger iteration) and figure 5 (who acted
// when in one episode, per method) drawn from the runs' own event logs, so they work on any run
// folder, finished or still running.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

#include "app/experiments.h"
#include "app/experiments/shared.h"
#include "core/method.h"
#include "core/text_file.h"
#include "ui/plot.h"

namespace dd::app {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::vector<json> read_events(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw Error(path + ": cannot open the event log");
  std::vector<json> out;
  int line_no = 0;
  for (std::string line; std::getline(f, line);) {
    ++line_no;
    if (line.empty()) continue;
    try {
      json j = json::parse(line);
      if (!j.is_object() || !j.contains("event")) throw Error("no field 'event'");
      out.push_back(std::move(j));
    } catch (const std::exception& e) {
      // a run killed mid-line leaves a partial last line: skip it, refuse anything else
      if (f.peek() == EOF) break;
      throw Error(fmt::format("{}:{}: not an event ({})", path, line_no, e.what()));
    }
  }
  return out;
}

const ui::Rgb kRobot{60, 110, 210}, kQuery{235, 120, 50}, kTimeout{200, 60, 60}, kDemo{80, 160, 90}, kOperator{150, 90, 190},
    kGaveUp{120, 72, 40};

ui::Rgb control_color(const std::string& control) {
  if (control == "robot") return kRobot;
  if (control == "expert_query") return kQuery;
  if (control == "expert_timeout") return kTimeout;
  if (control == "operator") return kOperator;
  return kDemo;
}

double number(const json& j, const char* key) { return j.contains(key) && j[key].is_number() ? j[key].get<double>() : 0.0; }

// One DAgger iteration: a policy update and the rollouts after it, up to the next update (or the end
// of the run). `complete`: the next update (or the run's end) has come, so the rollouts are all here.
struct Iteration {
  int update = 0;
  int demonstrations = 0, pairs = 0;
  double train_s = 0, threshold_s = 0;
  int threshold_refined = -1;  // pairs scored with all rows (Diff-DAgger's screened threshold; -1: not logged)
  int episodes = 0, robot_successes = 0, queries = 0, timeouts = 0;
  int64_t decisions = 0;
  double inference_s = 0;
  bool complete = false;
};

std::vector<Iteration> iteration_rows(const std::vector<json>& events) {
  std::vector<Iteration> rows;
  for (const json& e : events) {
    const std::string kind = e["event"];
    if (kind == "update_finished") {
      if (!rows.empty()) rows.back().complete = true;
      Iteration it;
      it.update = static_cast<int>(rows.size()) + 1;
      it.demonstrations = static_cast<int>(number(e, "expert_demos"));
      it.pairs = static_cast<int>(number(e, "pairs"));
      it.train_s = number(e, "train_s");
      it.threshold_s = number(e, "threshold_s");
      if (e.contains("threshold_refined")) it.threshold_refined = static_cast<int>(number(e, "threshold_refined"));
      rows.push_back(it);
      continue;
    }
    if (rows.empty()) continue;  // the initial demonstrations, before any policy
    Iteration& it = rows.back();
    if (kind == "decision") {
      ++it.decisions;
      it.inference_s += number(e, "inference_ms") / 1e3;
    } else if (kind == "episode_end") {
      ++it.episodes;
      it.robot_successes += e.value("control", "") == "robot" && e.value("success", false);
    } else if (kind == "query") {
      ++it.queries;
    } else if (kind == "timeout") {
      ++it.timeouts;
    } else if (kind == "done") {
      it.complete = true;
    }
  }
  return rows;
}

struct Run {
  std::string method;  // "diff", ... or the folder's name for a lone dagger run
  std::string log;
  std::vector<json> events;
  std::vector<Iteration> rows;  // iteration_rows(events)
};

// Figure 4's samples, wall-clock seconds per iteration: every update's training and threshold, and the
// robot's decisions of every iteration but the last (a finished run's last update has none after it;
// a running one's are not all in yet).
struct Iterations {
  std::vector<double> train, threshold, inference;
};

Iterations iterations(const Run& r) {
  Iterations it;
  const std::vector<Iteration>& rows = r.rows;
  for (size_t i = 0; i < rows.size(); ++i) {
    it.train.push_back(rows[i].train_s);
    it.threshold.push_back(rows[i].threshold_s);
    if (i + 1 < rows.size()) it.inference.push_back(rows[i].inference_s);
  }
  return it;
}

// Whether the run's method decides whether to ask: every method but BC. Decided by the method's name,
// not by the log: a run stopped right after its first update has no decision yet, and is no BC. A lone
// dagger run's folder is named by its user; there the log's decisions tell.
bool asks(const Run& r) {
  const std::vector<std::string> known = method_names();
  if (std::find(known.begin(), known.end(), r.method) != known.end()) return r.method != "bc";
  return std::any_of(r.events.begin(), r.events.end(), [](const json& e) { return e["event"] == "decision"; });
}

}  // namespace

std::vector<std::string> plot_runs(const PlotOptions& o) {
  if (!fs::is_directory(o.dir)) throw Error(o.dir + ": no such run folder");
  std::vector<Run> runs;
  if (fs::exists(o.dir + "/queries.jsonl")) {
    runs.push_back({fs::path(o.dir).filename().string(), o.dir + "/queries.jsonl", {}, {}});
  } else {
    for (const std::string& m : method_names()) {
      const std::string log = fmt::format("{}/runs/{}_seed{}/queries.jsonl", o.dir, m, o.seed);
      if (fs::exists(log)) runs.push_back({m, log, {}, {}});
    }
  }
  if (runs.empty())
    throw Error(fmt::format("{}: holds neither queries.jsonl (a dagger run) nor runs/METHOD_seed{}/queries.jsonl (an eval run)", o.dir, o.seed));
  for (Run& r : runs) {
    r.events = read_events(r.log);
    r.rows = iteration_rows(r.events);
  }

  int initial_demos = 0;
  if (fs::exists(o.dir + "/config.json")) {
    try {
      initial_demos = json::parse(read_text(o.dir + "/config.json")).at("dagger").at("initial_demos").get<int>();
    } catch (const json::exception& e) {
      throw Error(o.dir + "/config.json: no field dagger.initial_demos (" + std::string(e.what()) + ")");
    }
  }
  std::vector<std::string> written;

  // Figure 4: mean wall-clock per iteration and its spread over iterations, per method.
  {
    std::string csv = "method,asks,iterations,train_s,train_std,threshold_s,threshold_std,inference_s,inference_std,total_s\n", not_drawn;
    bool unmeasured = false;  // a run with no finished iteration: its inference and total are "-"
    ui::BarPanel panels[4];
    const char* titles[4] = {"training", "threshold setting", "inference", "total"};
    for (int k = 0; k < 4; ++k) {
      panels[k].title = titles[k];
      panels[k].y_label = "seconds per iteration";
      panels[k].width = 330;
    }
    for (const Run& r : runs) {
      const Iterations it = iterations(r);
      if (it.train.empty()) continue;  // no update yet
      const auto [tr, tr_sd] = mean_std(it.train);
      const auto [th, th_sd] = mean_std(it.threshold);
      // A run that asks but has not reached its second update has no iteration's decisions yet: its
      // inference, and so its total, is not measured (NaN: no bar, an empty CSV field), not 0.
      const double none = asks(r) ? NAN : 0.0;  // BC decides nothing between updates
      const auto [in, in_sd] = it.inference.empty() ? std::pair<double, double>{none, none} : mean_std(it.inference);
      unmeasured = unmeasured || std::isnan(in);
      const double values[4] = {tr, th, in, tr + th + in}, errors[4] = {tr_sd, th_sd, in_sd, 0};
      auto field = [](double v) { return std::isfinite(v) ? fmt::format("{:.4f}", v) : std::string(); };
      csv += fmt::format("{},{},{},{:.4f},{:.4f},{:.4f},{:.4f},{},{},{}\n", r.method, asks(r) ? "yes" : "no", it.train.size(), tr, tr_sd,
                         th, th_sd, field(in), field(in_sd), field(tr + th + in));
      if (!asks(r)) {
        // BC trains once, on its N_f demonstrations, and never asks: it has no iterations to draw
        not_drawn += fmt::format("; {} trained once ({:.0f} s), not drawn", method_title(r.method), tr);
        continue;
      }
      for (int k = 0; k < 4; ++k) {
        panels[k].categories.push_back(method_title(r.method));
        panels[k].values.push_back(values[k]);
        panels[k].errors.push_back(errors[k]);
        panels[k].colors.push_back(method_color(r.method));
      }
    }
    if (!panels[0].values.empty()) {
      write_text(o.dir + "/wallclock.csv", csv);
      ui::write_png(o.dir + "/figure4_wallclock.png",
                    ui::hstack({ui::draw_bars(panels[0]), ui::draw_bars(panels[1]), ui::draw_bars(panels[2]), ui::draw_bars(panels[3])},
                               fmt::format("wall-clock per DAgger iteration (mean, whisker: std over iterations), seed {}; "
                                           "inference counts the robot's decisions until the next update{}{}",
                                           o.seed, not_drawn, unmeasured ? "; -: no iteration finished yet" : "")));
      written.push_back(o.dir + "/wallclock.csv");
      written.push_back(o.dir + "/figure4_wallclock.png");
    }
  }

  // Per iteration: what each update cost and how many rollouts it took to reach the next one.
  {
    std::string csv =
        "method,update,demonstrations,pairs,train_s,threshold_s,threshold_refined,episodes,robot_successes,queries,timeouts,"
        "decisions,inference_s,ms_per_decision,complete\n";
    constexpr int kPanels = 6;
    const char* titles[kPanels] = {"training", "threshold setting", "robot's decisions until the next update",
                                   "episodes until the next update", "the rule's queries until the next update",
                                   "time-outs until the next update"};
    const char* y_labels[kPanels] = {"seconds", "seconds", "seconds", "episodes", "queries", "time-outs"};
    ui::LinePanel panels[kPanels];
    for (int k = 0; k < kPanels; ++k) {
      panels[k].title = titles[k];
      panels[k].x_label = "update";
      panels[k].y_label = y_labels[k];
      panels[k].y_min = 0;
      panels[k].width = 420;
      panels[k].height = 360;
    }
    bool partial = false;
    for (const Run& r : runs) {
      const std::vector<Iteration>& rows = r.rows;
      if (rows.empty()) continue;
      const bool draws = asks(r);  // BC trains once: a single point, no iterations to draw
      ui::LineSeries series[kPanels];
      for (ui::LineSeries& s : series) {
        s.name = method_title(r.method);
        s.color = method_color(r.method);
      }
      for (const Iteration& it : rows) {
        csv += fmt::format("{},{},{},{},{:.3f},{:.3f},{},{},{},{},{},{},{:.3f},{},{}\n", r.method, it.update, it.demonstrations, it.pairs,
                           it.train_s, it.threshold_s, it.threshold_refined >= 0 ? std::to_string(it.threshold_refined) : "",
                           it.episodes, it.robot_successes, it.queries, it.timeouts, it.decisions, it.inference_s,
                           it.decisions > 0 ? fmt::format("{:.1f}", 1e3 * it.inference_s / static_cast<double>(it.decisions)) : "",
                           it.complete ? 1 : 0);
        const double x = it.update;
        series[0].x.push_back(x);
        series[0].y.push_back(it.train_s);
        series[1].x.push_back(x);
        series[1].y.push_back(it.threshold_s);
        // a finished run's last update has no rollouts after it, and a running one's are not all in
        if (!it.complete && draws) partial = true;
        if (!it.complete || (&it == &rows.back())) continue;
        series[2].x.push_back(x);
        series[2].y.push_back(it.inference_s);
        const double counts[3] = {static_cast<double>(it.episodes), static_cast<double>(it.queries), static_cast<double>(it.timeouts)};
        for (int k = 3; k < kPanels; ++k) {
          series[k].x.push_back(x);
          series[k].y.push_back(counts[k - 3]);
        }
      }
      if (!draws) continue;
      for (int k = 0; k < kPanels; ++k)
        if (!series[k].x.empty()) panels[k].series.push_back(std::move(series[k]));
    }
    if (!panels[0].series.empty()) {
      double last_update = 1;
      for (const ui::LineSeries& s : panels[0].series) last_update = std::max(last_update, s.x.back());
      for (ui::LinePanel& panel : panels) {  // one update axis for all six
        panel.x_min = 0;
        panel.x_max = last_update + 1;
      }
      write_text(o.dir + "/iterations.csv", csv);
      ui::write_png(o.dir + "/figure_iterations.png",
                    ui::vstack({ui::hstack({ui::draw_lines(panels[0]), ui::draw_lines(panels[1]), ui::draw_lines(panels[2])}),
                                ui::hstack({ui::draw_lines(panels[3]), ui::draw_lines(panels[4]), ui::draw_lines(panels[5])},
                                           fmt::format("per DAgger iteration, seed {}: each update's cost, and the rollouts it took to reach the next "
                                           "(wall-clock){}",
                                           o.seed, partial ? "; a run still going: its last iteration's rollouts are left out" : ""))}));
      written.push_back(o.dir + "/iterations.csv");
      written.push_back(o.dir + "/figure_iterations.png");
    }
  }

  // Figure 5: who acted when in one episode (the same start state in every run: episodes are seeded
  // by their number), with the queries, and the query rule's score against its threshold.
  {
    const int episode = o.episode > 0 ? o.episode : initial_demos + 1;
    ui::TimelinePanel timeline;
    timeline.title = fmt::format("episode {}: who acted (seed {})", episode, o.seed);
    timeline.x_label = "control step";
    timeline.legend = {{"robot", kRobot}, {"expert (query)", kQuery}, {"expert (time limit)", kTimeout},
                       {"demonstration", kDemo}, {"operator", kOperator}};
    ui::LinePanel scores;
    scores.title = "the rule's score over its threshold at each decision (above 1: a violation)";
    scores.x_label = "control step";
    scores.y_label = "score / threshold";
    scores.width = timeline.width;
    scores.height = 300;
    std::string csv = "method,step,event,control,score,threshold\n";
    double last_step = 0;
    bool any_gave_up = false;
    for (const Run& r : runs) {
      if (!asks(r)) continue;  // BC never decides whether to ask: it has no row here
      ui::TimelineRow row;
      row.name = method_title(r.method);
      ui::LineSeries ratio;
      ratio.name = method_title(r.method);
      ratio.color = method_color(r.method);
      bool seen = false;
      std::string control;
      double from = 0;
      for (const json& e : r.events) {
        if (!e.contains("episode") || e["episode"].get<int>() != episode) continue;
        const std::string kind = e["event"];
        const double step = number(e, "step");
        const std::string c = e.value("control", "");
        if (kind == "episode_start") {
          seen = true;
          control = c;
          from = 0;
        } else if (kind == "takeover" || kind == "hand_back" || kind == "episode_end") {
          // a scripted expert that gave up (plugging: the charger lies toppled) ends the episode:
          // its last span gets its own colour
          const bool gave_up = kind == "episode_end" && e.value("gave_up", false);
          row.spans.push_back({from, step, gave_up ? kGaveUp : control_color(control)});
          any_gave_up = any_gave_up || gave_up;
          control = c;
          from = step;
        } else if (kind == "query") {
          row.marks.push_back(step);
        } else if (kind == "decision" && number(e, "threshold") > 0) {
          ratio.x.push_back(step);
          ratio.y.push_back(number(e, "score") / number(e, "threshold"));
        }
        last_step = std::max(last_step, step);
        csv += fmt::format("{},{},{},{},{},{}\n", r.method, step, kind, c, kind == "decision" ? fmt::format("{:.6g}", number(e, "score")) : "",
                           kind == "decision" ? fmt::format("{:.6g}", number(e, "threshold")) : "");
      }
      if (!seen) continue;  // this run has not reached the episode
      timeline.rows.push_back(std::move(row));
      if (!ratio.x.empty()) scores.series.push_back(std::move(ratio));
    }
    if (any_gave_up) timeline.legend.push_back({"expert, then gave up", kGaveUp});
    if (!timeline.rows.empty()) {
      // both panels on one time axis, the episode's end rounded up to a multiple of 10 steps
      const double x_end = std::max(10.0, std::ceil(last_step / 10) * 10);
      timeline.x_max = x_end;
      std::vector<ui::Image> panels{ui::draw_timeline(timeline)};
      if (!scores.series.empty()) {
        scores.series.push_back({"threshold", {0, x_end}, {1, 1}, {40, 40, 40}, /*markers=*/false});
        scores.y_min = 0;
        scores.x_min = 0;
        scores.x_max = x_end;
        scores.margin_left = ui::timeline_margin_left(timeline);
        scores.margin_right = ui::TimelinePanel::kMarginRight;
        panels.push_back(ui::draw_lines(scores));
      }
      write_text(o.dir + "/episode.csv", csv);
      ui::write_png(o.dir + "/figure5_episode.png", ui::vstack(panels));
      written.push_back(o.dir + "/episode.csv");
      written.push_back(o.dir + "/figure5_episode.png");
    }
  }
  if (written.empty())
    throw Error(fmt::format("{}: the runs have no policy update yet and none reached episode {}; nothing to plot", o.dir,
                            o.episode > 0 ? o.episode : initial_demos + 1));
  return written;
}

}  // namespace dd::app
