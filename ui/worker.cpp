#include "ui/worker.h"

#include <exception>

namespace dd::ui {

const char* to_string(WorkerJob job) {
  switch (job) {
    case WorkerJob::kUpdate: return "policy update";
    case WorkerJob::kField: return "loss field";
    case WorkerJob::kDecision: return "decision";
    case WorkerJob::kNone: break;
  }
  return "idle";
}

Worker::~Worker() {
  if (thread_.joinable()) thread_.join();
}

void Worker::start(WorkerJob kind, Job job) {
  if (busy()) std::terminate();  // a caller's bug: one job at a time
  kind_ = kind;
  progress_ = 0.f;
  finished_ = false;
  result_ = nullptr;
  thrown_.clear();
  thread_ = std::thread([this, job = std::move(job)] {
    try {
      result_ = job(progress_);
    } catch (const std::exception& e) {
      thrown_ = e.what();
      if (thrown_.empty()) thrown_ = "unknown error";
    } catch (...) {
      thrown_ = "unknown error";
    }
    finished_.store(true, std::memory_order_release);
  });
}

WorkerJob Worker::collect(bool wait) {
  if (!busy()) return WorkerJob::kNone;
  if (!wait && !finished_.load(std::memory_order_acquire)) return WorkerJob::kNone;
  thread_.join();
  const WorkerJob done = kind_;
  kind_ = WorkerJob::kNone;
  if (!thrown_.empty()) {
    error_ = thrown_;
  } else if (result_) {
    Apply apply = std::move(result_);
    result_ = nullptr;
    apply();
  }
  return done;
}

}  // namespace dd::ui
