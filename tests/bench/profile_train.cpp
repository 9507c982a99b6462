// Where a training step's time goes: runs warm-up steps, then profiles a few with libtorch's
// profiler and prints the self CPU time per operator (forward and backward), largest first. With
// `loss` last, the same for one expected loss (the gate's score) over `batch` noise rows, N_b.
//   build/tests/bench/profile_train [down_dims=32,64,128] [T_p=32] [batch=128] [steps=20] [train|loss]
#include <torch/csrc/autograd/profiler_legacy.h>
#include <torch/torch.h>

#include <cstdio>
#include <cstdlib>
#include <map>
#include <sstream>
#include <string>

#include "core/chunks.h"
#include "core/policy.h"
#include "core/runtime.h"
#include "core/synthetic.h"
#include "core/trainer.h"

int main(int argc, char** argv) {
  using namespace dd;
  std::vector<int> dims{32, 64, 128};
  if (argc > 1) {
    dims.clear();
    std::stringstream ss(argv[1]);
    for (std::string d; std::getline(ss, d, ',');) dims.push_back(std::stoi(d));
  }
  const int horizon = argc > 2 ? std::stoi(argv[2]) : 32, batch = argc > 3 ? std::stoi(argv[3]) : 128;
  const int steps = argc > 4 ? std::stoi(argv[4]) : 20;
  const bool loss = argc > 5 && std::string(argv[5]) == "loss";
  if (argc > 5 && !loss && std::string(argv[5]) != "train") {
    std::fprintf(stderr, "profile_train: the fifth argument is train or loss, not %s\n", argv[5]);
    return 2;
  }
  const int threads = set_num_threads();
  if (std::getenv("DD_NO_MKLDNN")) at::globalContext().setUserEnabledMkldnn(false);  // libtorch's own convolutions, for comparison
  PolicyConfig c;
  c.obs_dim = 24;
  c.action_dim = 7;
  c.horizon = horizon;
  c.unet.down_dims = dims;
  DiffusionPolicy policy(c, 0, false);
  const ChunkDataset data = ChunkDataset::from_episodes(bimodal_episodes(40, 80, 24, 7, 1), horizon);
  TrainConfig t;
  t.batch_size = batch;
  t.steps = 1000000;
  Trainer trainer(policy, data, t);
  for (int i = 0; i < 5; ++i) trainer.step();
  const Vec obs = data.obs.row(0).transpose();
  const Mat chunk = data.chunk(0);
  auto run = [&](int i) {
    if (loss) policy.expected_loss(obs, chunk, static_cast<uint64_t>(i), batch);
    else trainer.step();
  };
  for (int i = 0; i < 3; ++i) run(i);
  std::stringstream trace;
  {
    torch::autograd::profiler::RecordProfile profile(trace);
    for (int i = 0; i < steps; ++i) run(i);
  }
  // Chrome trace events: {"name": ..., "ph": "X", "ts": ..., "dur": ...}; self time = duration minus
  // the durations of the events nested directly inside it (same thread).
  struct Event {
    std::string name;
    double ts, dur;
    int tid;
  };
  std::vector<Event> events;
  const std::string s = trace.str();
  for (size_t p = s.find("\"name\""); p != std::string::npos; p = s.find("\"name\"", p + 1)) {
    const size_t q = s.find('"', s.find(':', p) + 1), r = s.find('"', q + 1);
    Event e{s.substr(q + 1, r - q - 1), 0, 0, 0};
    auto number = [&](const char* key) {
      const size_t k = s.find(key, r);
      return k == std::string::npos ? 0.0 : std::stod(s.substr(s.find(':', k) + 1));
    };
    e.ts = number("\"ts\"");
    e.dur = number("\"dur\"");
    e.tid = static_cast<int>(number("\"tid\""));
    events.push_back(e);
  }
  std::sort(events.begin(), events.end(), [](const Event& a, const Event& b) { return a.ts < b.ts || (a.ts == b.ts && a.dur > b.dur); });
  std::map<std::string, double> self;
  std::map<std::string, std::map<std::string, int>> callers;  // operator -> its direct callers, counted
  double total = 0;
  std::vector<const Event*> stack;
  for (const Event& e : events) {
    while (!stack.empty() && (stack.back()->tid != e.tid || stack.back()->ts + stack.back()->dur <= e.ts)) stack.pop_back();
    self[e.name] += e.dur;
    if (!stack.empty()) self[stack.back()->name] -= e.dur;
    else total += e.dur;
    ++callers[e.name][stack.empty() ? "(top level)" : stack.back()->name];
    stack.push_back(&e);
  }
  std::vector<std::pair<double, std::string>> rows;
  for (const auto& [name, us] : self) rows.emplace_back(us, name);
  std::sort(rows.rbegin(), rows.rend());
  std::printf("down_dims %s T_p %d %s %d, %d threads: %.1f ms per %s (profiled)\n", argc > 1 ? argv[1] : "32,64,128", horizon,
              loss ? "N_b" : "batch", batch, threads, total / 1000.0 / steps, loss ? "expected loss" : "step");
  for (size_t i = 0; i < rows.size() && i < 25; ++i) {
    std::string from;
    for (const auto& [caller, n] : callers[rows[i].second]) from += (from.empty() ? "" : ", ") + caller + " x" + std::to_string(n / steps);
    std::printf("%6.1f%%  %8.2f ms/step  %s  <- %s\n", 100 * rows[i].first / total, rows[i].first / 1000.0 / steps,
                rows[i].second.c_str(), from.c_str());
  }
  return 0;
}
