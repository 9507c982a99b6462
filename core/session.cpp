#include "core/session.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>

#include <nlohmann/json.hpp>

#include "core/config.h"
#include "core/json_read.h"
#include "core/text_file.h"

namespace dd {

void DaggerConfig::validate() const {
  auto check = [](bool ok, const char* field, const std::string& why) {
    if (!ok) throw Error(std::string("dagger.") + field + ": " + why);
  };
  check(initial_demos >= 1, "initial_demos", "must be >= 1");
  check(final_demos >= initial_demos, "final_demos", "must be >= initial_demos");
  check(demos_per_update >= 1, "demos_per_update", "must be >= 1");
  check(patience >= 1, "patience", "must be >= 1");
  check(time_limit >= 1, "time_limit", "must be >= 1");
  check(expert_time_limit == 0 || expert_time_limit >= time_limit, "expert_time_limit", "must be 0 or >= time_limit");
  check(action_steps >= 1, "action_steps", "must be >= 1");
  check(max_episodes >= 0, "max_episodes", "must be >= 0");
}

std::string to_string(GateCadence g) { return g == GateCadence::kStep ? "step" : "chunk"; }

std::string to_string(Control c) { return kActorLabels[static_cast<int>(c)]; }

std::string to_string(EventKind k) {
  switch (k) {
    case EventKind::kEpisodeStart: return "episode_start";
    case EventKind::kDecision: return "decision";
    case EventKind::kQuery: return "query";
    case EventKind::kTakeover: return "takeover";
    case EventKind::kHandBack: return "hand_back";
    case EventKind::kTimeout: return "timeout";
    case EventKind::kEpisodeEnd: return "episode_end";
    case EventKind::kUpdateStarted: return "update_started";
    case EventKind::kUpdateProgress: return "update_progress";
    case EventKind::kUpdateFinished: return "update_finished";
    case EventKind::kDone: return "done";
  }
  return "?";
}

DaggerSession::DaggerSession(Env& env, Expert& expert, Method& method, const DaggerConfig& config, const TrainConfig& train,
                             DatasetWriter* writer)
    : env_(env), expert_(expert), method_(method), config_(config), train_(train), writer_(writer), gate_(0.f, config.patience),
      expert_noise_(expert, env.action_dim()) {
  config_.validate();
  train_.validate();
  if (config_.expert_time_limit == 0) config_.expert_time_limit = 2 * config_.time_limit;
}

void DaggerSession::add_observer(SessionObserver observer) { observers_.push_back(std::move(observer)); }

void DaggerSession::emit(SessionEvent e) {
  e.episode = episode_;
  e.step = in_episode_ ? env_.steps() : 0;
  e.control = control_;
  e.expert_demos = expert_demos_;
  e.interventions = interventions_;
  e.updates = updates_;
  for (auto& o : observers_) o(e);
}

bool DaggerSession::tick() {
  if (done_) return false;
  if (update_pending_) {
    run_update();
    return !done_;
  }
  if (!in_episode_) start_episode();

  const Vec obs = env_.observation();
  if (control_ == Control::kRobot) {
    if (env_.steps() >= config_.time_limit) {
      emit({EventKind::kTimeout});
      hand_over(Control::kExpertTimeout);
    } else if (decision_due()) {
      const bool need_chunk = chunk_.rows() == 0 || chunk_pos_ >= config_.action_steps;
      MethodDecision d;
      double took = 0;
      if (provided_) {
        d = std::move(provided_decision_);
        took = provided_seconds_;
        provided_ = false;
        ++decisions_;
      } else {
        const auto t = std::chrono::steady_clock::now();
        d = method_.decide(obs, episode_seed_ * 7919 + decisions_++);
        took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
      }
      inference_s_ += took;
      const GateDecision g = method_.gated() ? gate_.record(d.violation) : GateDecision{};
      SessionEvent e{EventKind::kDecision};
      e.score = d.score;
      e.score_rows = d.score_rows;
      e.threshold = d.threshold;
      e.risk_q = d.risk_q;
      e.violation = g.violation;
      e.reason = method_.gated() ? d.reason : QueryReason::kNone;
      e.run = g.run;
      e.inference_s = took;
      emit(e);
      if (g.query) {
        emit({EventKind::kQuery});
        hand_over(Control::kExpertQuery);
      } else if (need_chunk) {
        chunk_ = d.chunk;
        chunk_pos_ = 0;
      }
    }
  }
  const bool robot = control_ == Control::kRobot;
  if (!robot && control_ != Control::kOperator && expert_.gave_up(env_)) {
    expert_gave_up_ = true;  // the scripted expert cannot finish from here: its failure, now
    end_episode();
    return !done_;
  }
  const Vec action = robot ? Vec(chunk_.row(chunk_pos_++).transpose()) : expert_.act(env_);
  obs_.push_back(obs);
  actions_.push_back(action);
  flags_.push_back(robot ? 0 : 1);
  actors_.push_back(static_cast<uint8_t>(actor()));
  // A "+noise" scripted expert acts as in `collect` (expert_episode): its own action is recorded, its
  // action plus Gaussian noise is executed, in its demonstrations and its interventions alike.
  const Vec executed = !robot && control_ != Control::kOperator ? expert_noise_.apply(action) : action;
  if (env_.step(executed).done) end_episode();
  return !done_;
}

// The data set's actor codes are the Control values, in kActorLabels' order.
static_assert(static_cast<int>(Control::kRobot) == 0 && static_cast<int>(Control::kExpertQuery) == 1 &&
              static_cast<int>(Control::kExpertTimeout) == 2 && static_cast<int>(Control::kExpertDemo) == 3 &&
              static_cast<int>(Control::kOperator) == 4 && std::size(kActorLabels) == 5);

void DaggerSession::hand_over(Control to) {
  control_ = to;
  provided_ = false;
  expert_acted_ = true;
  emit({EventKind::kTakeover});
}

bool DaggerSession::prepare() {
  if (!done_ && !update_pending_ && !in_episode_) start_episode();
  return in_episode_;
}

bool DaggerSession::decision_due() const {
  return in_episode_ && !update_pending_ && control_ == Control::kRobot && env_.steps() < config_.time_limit &&
         (chunk_.rows() == 0 || chunk_pos_ >= config_.action_steps ||
          (config_.gate_every == GateCadence::kStep && method_.gated()));
}

void DaggerSession::provide_decision(MethodDecision decision, double seconds) {
  provided_decision_ = std::move(decision);
  provided_seconds_ = seconds;
  provided_ = true;
}

void DaggerSession::end_episode_now() {
  if (in_episode_ && !obs_.empty()) {
    cut_short_ = true;  // stopped by the operator: not an expert failure, its expert steps are kept
    end_episode();
  } else {
    in_episode_ = false;
  }
}

bool DaggerSession::take_over() {
  if (done_ || update_pending_ || !in_episode_ || control_ != Control::kRobot) return false;
  hand_over(Control::kOperator);
  return true;
}

bool DaggerSession::operator_answers_query() {
  if (!in_episode_ || control_ != Control::kExpertQuery) return false;
  operator_answering_ = true;
  return true;
}

bool DaggerSession::hand_back() {
  if (!in_episode_ || (control_ != Control::kExpertQuery && control_ != Control::kOperator)) return false;
  control_ = Control::kRobot;
  operator_answering_ = false;
  gate_.reset();
  chunk_.resize(0, 0);
  chunk_pos_ = 0;
  provided_ = false;
  emit({EventKind::kHandBack});
  return true;
}

void DaggerSession::start_episode() {
  ++episode_;
  episode_seed_ = config_.seed * 1000003ull + static_cast<uint64_t>(episode_);
  env_.reset(episode_seed_);
  expert_.reset(episode_seed_);
  expert_noise_.reset(episode_seed_);
  env_.set_time_limit(config_.expert_time_limit);
  gate_.reset();
  chunk_.resize(0, 0);
  chunk_pos_ = 0;
  provided_ = false;
  obs_.clear();
  actions_.clear();
  flags_.clear();
  actors_.clear();
  operator_answering_ = false;
  const int demos_wanted = method_.gated() ? config_.initial_demos : config_.final_demos;
  control_ = expert_demos_ < demos_wanted ? Control::kExpertDemo : Control::kRobot;
  expert_acted_ = control_ == Control::kExpertDemo;
  in_episode_ = true;
  emit({EventKind::kEpisodeStart});
}

void DaggerSession::end_episode() {
  RecordedEpisode rec;
  const auto T = static_cast<Eigen::Index>(obs_.size());
  rec.obs = stack_rows(obs_, env_.obs_dim());
  rec.actions = stack_rows(actions_, env_.action_dim());
  rec.intervention = flags_;
  rec.actor = actors_;
  rec.success = env_.success();
  rec.rewards.assign(static_cast<size_t>(T), 0.f);
  if (rec.success && T > 0) rec.rewards.back() = 1.f;
  rec.dones.assign(static_cast<size_t>(T), 0);
  if (T > 0) rec.dones.back() = 1;
  const bool expert_acted = expert_acted_;
  rec.source = control_ == Control::kExpertDemo ? "expert" : (expert_acted ? "intervention" : "robot");

  SessionEvent end{EventKind::kEpisodeEnd};
  end.success = rec.success;
  end.gave_up = expert_gave_up_;
  expert_gave_up_ = false;
  if (expert_acted && T > 0 && flags_.front() == 0) {
    // the robot's part, up to the takeover, ends in a non-success
    const auto robot_steps = static_cast<Eigen::Index>(std::find(flags_.begin(), flags_.end(), 1) - flags_.begin());
    RecordedEpisode part;
    part.obs = rec.obs.topRows(robot_steps);
    part.actions = rec.actions.topRows(robot_steps);
    part.actor.assign(static_cast<size_t>(robot_steps), static_cast<uint8_t>(Control::kRobot));
    part.success = false;
    part.source = "robot";
    robot_data_.push_back(std::move(part));
  }
  // A scripted expert that failed gives no training data (the operator's steps are always kept).
  const bool expert_failed = expert_acted && !rec.success && control_ != Control::kOperator && !cut_short_;
  cut_short_ = false;
  if (expert_acted && T > 0 && expert_failed) {
    if (writer_) writer_->append(rec);  // kept in the data set, flagged success = 0
    ++expert_failures_;
  } else if (expert_acted && T > 0) {
    if (writer_) writer_->append(rec);  // durable before the next episode begins
    expert_data_.push_back(rec.expert_steps());
    ++expert_demos_;
    if (control_ == Control::kExpertDemo) {
      const int demos_wanted = method_.gated() ? config_.initial_demos : config_.final_demos;
      if (expert_demos_ == demos_wanted) update_pending_ = true;
    } else {
      ++interventions_;
      if (interventions_ % config_.demos_per_update == 0) update_pending_ = true;
    }
  } else if (T > 0) {
    robot_data_.push_back(std::move(rec));
  }
  emit(end);
  in_episode_ = false;
  const bool out_of_episodes = config_.max_episodes > 0 && episode_ >= config_.max_episodes;
  if (expert_demos_ >= config_.final_demos || out_of_episodes) {
    finishing_ = true;
    if (demos_at_last_update_ != expert_demos_) {
      update_pending_ = true;  // a last update on everything, then done
    } else if (!update_pending_) {
      done_ = true;  // the policy already saw every demonstration
      emit({EventKind::kDone});
    }
  }
}

void DaggerSession::run_update(const ProgressFn& progress) { finish_update(compute_update(progress)); }

UpdateReport DaggerSession::compute_update(const ProgressFn& progress) {
  emit({EventKind::kUpdateStarted});
  int last_percent = -1;
  const ProgressFn report_progress = [&](int done, int total, double value) {
    if (progress) progress(done, total, value);
    const int percent = total > 0 ? done * 100 / total : 100;
    if (percent != last_percent) {
      last_percent = percent;
      SessionEvent e{EventKind::kUpdateProgress};
      e.progress = percent / 100.0;
      emit(e);
    }
  };
  return updates_ == 0 && !adopt_.empty() ? method_.adopt(adopt_, expert_data_, robot_data_, report_progress)
                                          : method_.update(expert_data_, robot_data_, train_, report_progress);
}

void DaggerSession::finish_update(const UpdateReport& r) {
  ++updates_;
  demos_at_last_update_ = expert_demos_;
  update_pending_ = false;
  gate_.set_threshold(r.threshold);
  reports_.push_back(r);
  inference_s_ = 0;
  SessionEvent e{EventKind::kUpdateFinished};
  e.report = r;
  emit(e);
  if (finishing_) {
    done_ = true;
    emit({EventKind::kDone});
  }
}

void DaggerSession::save_state(const std::string& dir) const {
  if (in_episode_ || update_pending_)
    throw Error("session: its state is saved between episodes with no update pending (an episode or an update is under way)");
  std::filesystem::create_directories(dir);
  // The data first: a session.json on disk always has its data beside it.
  const std::string data = dir + "/session.hdf5";
  if (expert_data_.empty() && robot_data_.empty()) {
    std::error_code ec;
    std::filesystem::remove(data, ec);  // no data yet: no file
  } else {
    std::vector<RecordedEpisode> episodes;
    episodes.reserve(expert_data_.size() + robot_data_.size());
    for (const Episode& e : expert_data_) {
      RecordedEpisode r;
      r.obs = e.obs;
      r.actions = e.actions;
      r.intervention.assign(static_cast<size_t>(e.obs.rows()), 1);
      r.success = true;
      r.source = "expert";
      episodes.push_back(std::move(r));
    }
    episodes.insert(episodes.end(), robot_data_.begin(), robot_data_.end());
    write_dataset(data, R"({"what": "session state"})", episodes);
  }
  nlohmann::json reports = nlohmann::json::array();
  for (const UpdateReport& r : reports_)
    reports.push_back({{"train_s", r.train_s}, {"threshold_s", r.threshold_s}, {"threshold", r.threshold}, {"pairs", r.pairs},
                       {"final_loss", r.final_loss}, {"train_reused", r.train_reused},
                       {"threshold_pairs", r.threshold_pairs}, {"threshold_refined", r.threshold_refined}});
  const nlohmann::json j{{"episode", episode_}, {"expert_demos", expert_demos_}, {"interventions", interventions_},
                         {"updates", updates_}, {"demos_at_last_update", demos_at_last_update_},
                         {"expert_failures", expert_failures_}, {"finishing", finishing_}, {"done", done_},
                         {"decisions", decisions_}, {"inference_s", inference_s_}, {"reports", reports},
                         {"expert_episodes", expert_data_.size()}, {"robot_episodes", robot_data_.size()}};
  write_text(dir + "/session.json", j.dump(2) + "\n");
}

void DaggerSession::load_state(const std::string& dir) {
  const std::string path = dir + "/session.json", data = dir + "/session.hdf5";
  nlohmann::json j;
  size_t n_expert = 0, n_robot = 0;
  std::vector<UpdateReport> reports;
  // every counter, checked to exist and to fit its type (an Error names the file and field)
  struct Counters {
    int episode, expert_demos, interventions, updates, demos_at_last_update, expert_failures;
    bool finishing, done;
    uint64_t decisions;
  } c{};
  try {
    j = nlohmann::json::parse(read_text(path));
    auto field = [&](const nlohmann::json& o, const char* key) -> const nlohmann::json& {
      if (!o.is_object() || !o.contains(key)) throw Error(path + ": missing field '" + key + "'");
      return o.at(key);
    };
    auto num = [&](const nlohmann::json& o, const char* key, auto& out) {
      out = json_read::get_checked<std::decay_t<decltype(out)>>(field(o, key), path + ": field '" + key + "'");
    };
    num(j, "expert_episodes", n_expert);
    num(j, "robot_episodes", n_robot);
    if (!field(j, "reports").is_array()) throw Error(path + ": field 'reports' must be a list");
    for (const auto& r : j.at("reports")) {
      UpdateReport u;
      num(r, "train_s", u.train_s);
      num(r, "threshold_s", u.threshold_s);
      if (field(r, "threshold").is_null()) u.threshold = std::numeric_limits<float>::infinity();  // JSON has no inf
      else num(r, "threshold", u.threshold);
      num(r, "pairs", u.pairs);
      num(r, "final_loss", u.final_loss);
      if (r.contains("train_reused")) num(r, "train_reused", u.train_reused);  // absent in states written before it
      if (r.contains("threshold_pairs")) num(r, "threshold_pairs", u.threshold_pairs);  // likewise
      if (r.contains("threshold_refined")) num(r, "threshold_refined", u.threshold_refined);
      reports.push_back(u);
    }
    num(j, "episode", c.episode);
    num(j, "expert_demos", c.expert_demos);
    num(j, "interventions", c.interventions);
    num(j, "updates", c.updates);
    num(j, "demos_at_last_update", c.demos_at_last_update);
    num(j, "expert_failures", c.expert_failures);
    num(j, "finishing", c.finishing);
    num(j, "done", c.done);
    num(j, "decisions", c.decisions);
    if (static_cast<int>(reports.size()) != c.updates)
      throw Error(path + ": field 'reports' holds " + std::to_string(reports.size()) + " updates, field 'updates' says " +
                  std::to_string(c.updates));
  } catch (const nlohmann::json::exception& e) {
    throw Error(path + ": not a session state (" + std::string(e.what()) + ")");
  }
  std::vector<RecordedEpisode> episodes = n_expert + n_robot > 0 ? read_dataset(data) : std::vector<RecordedEpisode>{};
  if (episodes.size() != n_expert + n_robot)
    throw Error(data + ": holds " + std::to_string(episodes.size()) + " episodes, " + path + " says " + std::to_string(n_expert) +
                " expert and " + std::to_string(n_robot) + " robot episodes");
  expert_data_.clear();
  robot_data_.clear();
  for (size_t i = 0; i < episodes.size(); ++i) {
    if (i < n_expert) expert_data_.push_back(episodes[i].all_steps());
    else robot_data_.push_back(std::move(episodes[i]));
  }
  episode_ = c.episode;
  expert_demos_ = c.expert_demos;
  interventions_ = c.interventions;
  updates_ = c.updates;
  demos_at_last_update_ = c.demos_at_last_update;
  expert_failures_ = c.expert_failures;
  finishing_ = c.finishing;
  done_ = c.done;
  decisions_ = c.decisions;
  inference_s_ = j["inference_s"].get<double>();
  reports_ = std::move(reports);
  if (!reports_.empty()) gate_.set_threshold(reports_.back().threshold);
  in_episode_ = update_pending_ = provided_ = cut_short_ = expert_gave_up_ = false;
  chunk_.resize(0, 0);
  chunk_pos_ = 0;
}

}  // namespace dd
