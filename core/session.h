// Algorithm 1 of the paper as a session advanced one control tick at a time, so that the console,
// a headless script and a batch run all drive the same code.
//
//   initial demos   the expert demonstrates N_i episodes, then the first policy update
//   robot           the robot plans a chunk, executes T_a actions of it, plans again; each decision
//                   goes through the method's query rule and the patience-K gate
//   expert (query)  after K violations in a row the expert takes over from the current state and
//                   finishes the episode; its steps are recorded with the intervention flag
//   expert (timeout) the same when the robot has neither asked nor finished within T_L steps
//   update          after every N_d interventions: train on all expert data, then set the threshold
// An episode in which the scripted expert acted and failed is written to the data set (success 0) but
// kept out of training and of the counts N_i, N_d and N_f (an episode the operator ends early is not a
// failure: its expert steps are kept). The robot's part of an intervened episode
// is kept as robot data ending in a non-success (Thrifty's critic learns from it).
//   done            when N_f expert demonstrations exist (after a last update that includes them all),
//                   or after max_episodes episodes when a robot rarely needs help
// An episode the robot finishes by itself adds no expert data (Thrifty's critic learns from it).
//
// BC never asks: its session demonstrates N_f episodes and trains once.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/dataset.h"
#include "core/env.h"
#include "core/gate.h"
#include "core/method.h"

namespace dd {

/// How often the query rule scores: once per generated chunk (K counts chunks), or at every control
/// step with a freshly sampled chunk (K counts steps; the authors' released code). Either way the robot
/// executes T_a actions of the chunk generated at the start of each action horizon.
enum class GateCadence { kChunk, kStep };
std::string to_string(GateCadence g);

/// The data-aggregation schedule (the paper's Table III columns).
struct DaggerConfig {
  int initial_demos = 10;     // N_i
  int final_demos = 30;       // N_f
  int demos_per_update = 4;   // N_d: interventions between policy updates
  int patience = 2;           // K
  int time_limit = 200;       // T_L: robot steps before the expert takes over automatically
  int expert_time_limit = 0;  // steps an episode may run in all, expert included (0: 2 * T_L)
  int action_steps = 8;       // T_a: actions executed per chunk
  int max_episodes = 0;       // stop after this many episodes even short of N_f (0: no bound)
  GateCadence gate_every = GateCadence::kChunk;
  uint64_t seed = 0;

  void validate() const;
};

/// Who is acting.
/// kOperator: a person took over without being asked (human-gated, from the console).
enum class Control { kRobot, kExpertQuery, kExpertTimeout, kExpertDemo, kOperator };
std::string to_string(Control c);

enum class EventKind {
  kEpisodeStart, kDecision, kQuery, kTakeover, kHandBack, kTimeout, kEpisodeEnd,
  kUpdateStarted, kUpdateProgress, kUpdateFinished, kDone
};
std::string to_string(EventKind k);

/// What happened; fields beyond kind/episode/step/control are filled where they apply.
struct SessionEvent {
  SessionEvent(EventKind k = EventKind::kEpisodeStart) : kind(k) {}  // NOLINT: events are built from their kind
  EventKind kind;
  int episode = 0;           // 1-based episode number
  int step = 0;              // env step within the episode
  Control control = Control::kRobot;
  float score = 0;           // kDecision: the method's score (loss or variance)
  int score_rows = 0;        // kDecision: rows of noise a loss score is the mean of (MethodDecision::score_rows)
  float threshold = 0;       // kDecision: the threshold it was compared with
  float risk_q = -1;         // kDecision (thrifty): min Q
  bool violation = false;    // kDecision
  QueryReason reason = QueryReason::kNone;  // kDecision: why it violates (score or, thrifty, risk)
  int run = 0;               // kDecision: violations in a row
  double inference_s = 0;    // kDecision: time the decision took
  bool success = false;      // kEpisodeEnd
  bool gave_up = false;      // kEpisodeEnd: ended early because the scripted expert gave up (Expert::gave_up)
  double progress = 0;       // kUpdateProgress: 0..1
  UpdateReport report;       // kUpdateFinished
  int expert_demos = 0, interventions = 0, updates = 0;  // counts after the event
};

using SessionObserver = std::function<void(const SessionEvent&)>;

class DaggerSession {
 public:
  /// The session borrows env, expert and method; `writer` (optional) receives every episode in which
  /// the expert acted, as soon as it ends.
  DaggerSession(Env& env, Expert& expert, Method& method, const DaggerConfig& config, const TrainConfig& train,
                DatasetWriter* writer = nullptr);

  /// Observers are called synchronously, in order, for every event.
  void add_observer(SessionObserver observer);

  /// Advances one control step, or runs a pending policy update. Returns false once done.
  bool tick();
  /// Runs the pending policy update now: compute_update(), then finish_update().
  void run_update(const ProgressFn& progress = {});
  /// The pending update's training and threshold, leaving the session as it was: the console runs it
  /// on its worker thread while the frame thread keeps reading the session (nothing may change the
  /// session until finish_update). Emits kUpdateStarted and kUpdateProgress.
  UpdateReport compute_update(const ProgressFn& progress = {});
  /// Records compute_update()'s report: counts the update, sets the gate's threshold, and emits
  /// kUpdateFinished (and kDone when the session was finishing).
  void finish_update(const UpdateReport& report);
  /// The first update adopts these checkpoints (Method::adopt: a policy trained elsewhere, e.g. one
  /// imported from diffusion_policy) instead of training; its threshold is still set on the initial
  /// demonstrations. Later updates train as usual. Call before the first update.
  void adopt_at_first_update(std::vector<std::string> checkpoints) { adopt_ = std::move(checkpoints); }
  /// The operator takes over from the robot in the middle of an episode (Control::kOperator). The
  /// steps from here on are recorded as an intervention. False (and nothing happens) unless the robot
  /// is in control.
  bool take_over();
  /// Control goes back to the robot after a query or an operator takeover: the gate starts counting
  /// afresh and the robot plans a new chunk. False unless an expert answering a query or the operator
  /// is in control (a time-out or a demonstration cannot be handed back).
  bool hand_back();
  /// The operator, not the scripted expert, answers the query in progress: its steps are recorded
  /// with the actor label "operator" (the console routes the actions; control stays kExpertQuery).
  /// False unless a query is being answered.
  bool operator_answers_query();
  /// Who acts in this step: control(), except kOperator while the operator answers a query (what the
  /// data set's actor label records and what a display should show).
  Control actor() const { return operator_answering_ && control_ == Control::kExpertQuery ? Control::kOperator : control_; }
  /// Starts the next episode now if one is due (no update pending, not done); tick() would start it
  /// itself. Returns whether an episode is in progress. Lets a caller see the first decision coming.
  bool prepare();
  /// True when the next tick() will ask the method for a decision (at a chunk boundary, or at every
  /// robot step with GateCadence::kStep).
  bool decision_due() const;
  /// The seed the current (or last) episode's env, expert and execution noise were reset with.
  uint64_t episode_seed() const { return episode_seed_; }
  /// The seed the next decision uses.
  uint64_t next_decision_seed() const { return episode_seed_ * 7919 + decisions_; }
  /// Hands in the decision for the next tick (computed elsewhere, e.g. on a worker thread, with
  /// method.decide(observation(), next_decision_seed())); the tick then uses it instead of deciding.
  void provide_decision(MethodDecision decision, double seconds);
  /// Ends the current episode where it stands (a reset, or the console closing): it is recorded like
  /// any other, so the expert steps it holds reach the data set. No-op between episodes.
  void end_episode_now();
  /// The chunk the robot is executing and the index of its next action (empty when none).
  const Mat& chunk() const { return chunk_; }
  int chunk_pos() const { return chunk_pos_; }
  /// True while the current episode has had expert steps (so it will be recorded as expert data).
  bool expert_acted() const { return expert_acted_; }

  /// Writes what continuing needs into `dir` (created if needed): session.json (the counters, the
  /// decision counter, the update reports) and session.hdf5 (the expert and robot data so far).
  /// Allowed between episodes with no update pending, e.g. right after an update; throws Error
  /// otherwise, or naming the file when it cannot be written.
  void save_state(const std::string& dir) const;
  /// Reads save_state()'s files into a session built over the same env, expert, config and a method
  /// restored with Method::load_state(): it then goes on exactly as the saved one would have. Throws
  /// Error naming the file and field that is missing or malformed.
  void load_state(const std::string& dir);

  bool done() const { return done_; }
  bool update_pending() const { return update_pending_; }
  bool in_episode() const { return in_episode_; }
  Control control() const { return control_; }
  int episode() const { return episode_; }
  int expert_demos() const { return expert_demos_; }
  int interventions() const { return interventions_; }
  int updates() const { return updates_; }
  /// Episodes in which the scripted expert failed (recorded, not trained on, not counted).
  int expert_failures() const { return expert_failures_; }
  const std::vector<UpdateReport>& reports() const { return reports_; }
  /// Decision time spent since the last update began (for the wall-clock comparison).
  double inference_s_since_update() const { return inference_s_; }
  const std::vector<Episode>& expert_data() const { return expert_data_; }

 private:
  void start_episode();
  void end_episode();
  void emit(SessionEvent e);
  void hand_over(Control to);

  Env& env_;
  Expert& expert_;
  Method& method_;
  std::vector<std::string> adopt_;  // adopt_at_first_update()
  DaggerConfig config_;
  TrainConfig train_;
  DatasetWriter* writer_;
  QueryGate gate_;
  std::vector<SessionObserver> observers_;

  bool done_ = false, update_pending_ = false, finishing_ = false, in_episode_ = false, expert_acted_ = false;
  Control control_ = Control::kExpertDemo;
  int episode_ = 0, expert_demos_ = 0, interventions_ = 0, updates_ = 0, demos_at_last_update_ = -1, expert_failures_ = 0;
  uint64_t episode_seed_ = 0, decisions_ = 0;
  ExecutionNoise expert_noise_;  // the scripted expert's execution noise, restarted each episode
  Mat chunk_;
  int chunk_pos_ = 0;
  bool provided_ = false;
  bool cut_short_ = false;  // end_episode_now() is ending this episode
  bool expert_gave_up_ = false;  // the expert gave up (Expert::gave_up): tick() is ending this episode
  MethodDecision provided_decision_;
  double provided_seconds_ = 0;
  double inference_s_ = 0;
  std::vector<Vec> obs_, actions_;
  std::vector<uint8_t> flags_;
  std::vector<uint8_t> actors_;  // who acted at each step (a Control, as the data set's actor codes)
  bool operator_answering_ = false;  // the query in progress is answered by the operator
  std::vector<Episode> expert_data_;
  std::vector<RecordedEpisode> robot_data_;
  std::vector<UpdateReport> reports_;
};

}  // namespace dd
