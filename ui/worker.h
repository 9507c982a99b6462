// The console's worker thread: one background job at a time (a policy update, the loss field, a
// robot decision), whose result reaches the console's state on the frame thread only.
//
// A job runs on the worker and returns what to do with its result: a closure that collect() runs
// on the frame thread at the start of a frame. So no field of the console is written by two
// threads: the worker writes only its own locals and the progress (an atomic), and the frame
// thread applies the result after joining the worker thread.
#pragma once

#include <atomic>
#include <functional>
#include <string>
#include <thread>

namespace dd::ui {

enum class WorkerJob { kNone, kUpdate, kField, kDecision };
const char* to_string(WorkerJob job);  // "policy update", "loss field", "decision", "idle"

class Worker {
 public:
  using Apply = std::function<void()>;                          // runs on the frame thread
  using Job = std::function<Apply(std::atomic<float>& progress)>;  // runs on the worker thread

  Worker() = default;
  ~Worker();  // waits for a running job (its result is dropped)
  Worker(const Worker&) = delete;
  Worker& operator=(const Worker&) = delete;

  /// Frame thread: starts `job` on the worker thread. Only when job() is WorkerJob::kNone.
  void start(WorkerJob kind, Job job);
  /// Frame thread: when the job has finished, joins the worker thread and runs the job's Apply (or,
  /// when the job threw, records its message in error()). With `wait`, waits for it to finish.
  /// Returns the kind of job collected, or kNone.
  WorkerJob collect(bool wait = false);

  /// The job started and not yet collected (frame thread), and its progress in [0, 1] (any thread).
  WorkerJob job() const { return kind_; }
  bool busy() const { return kind_ != WorkerJob::kNone; }
  float progress() const { return progress_.load(std::memory_order_relaxed); }
  /// The message of the last job that threw ("" when none did); frame thread.
  const std::string& error() const { return error_; }

 private:
  WorkerJob kind_ = WorkerJob::kNone;
  std::thread thread_;
  std::atomic<bool> finished_{false};
  std::atomic<float> progress_{0.f};
  // written by the worker thread before finished_ is set, read by the frame thread after the join
  Apply result_;
  std::string thrown_;
  std::string error_;
};

}  // namespace dd::ui
