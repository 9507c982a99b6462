// Reading a file with a library that is not safe on hostile input, in a child process.
//
// Fuzzing the loaders (tests/fuzz) found heap overflows inside the libraries themselves: libhdf5
// 1.10.8 (H5O__attr_exists on a corrupt object header) and libtorch 1.13's zip reader (miniz, on a
// corrupt central directory). Neither can be patched here, so a file a user points at is parsed in a
// forked child first: when the library crashes or aborts, only the child dies, and the caller gets an
// Error naming the file instead of a crash or a corrupted heap.
#pragma once

#include <cstdint>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "core/config.h"
#include "core/types.h"

namespace dd {

/// Runs `read` in a forked child process and returns the bytes it returned. When `read` throws, its
/// message is rethrown as an Error; when the child dies (a signal, a sanitizer's abort), throws
/// Error("<path>: the file is corrupt: reading it crashed <library> ..."). The child runs `read` on
/// one thread (OpenMP's pool is set to one); `read` must not start threads or pools of its own
/// (at::set_num_threads does: it hangs after a fork). A child that sleeps for 3 s without using any
/// CPU (deadlocked on a lock another thread held at the fork) is killed and the read started again;
/// after 3 such tries, Error("<path>: reading it with <library> stalled: ...").
std::string read_in_child(const std::string& path, const std::string& library, const std::function<std::string()>& read);

/// With DD_READ_IN_PROCESS set in the environment, `read` runs in this process instead (for the
/// fuzzers' deep runs, which need the reading code's coverage; never for users).
///
/// Inputs whose reading crashed a child so far in this process.
int children_crashed();

/// Child processes started so far in this process (run_in_children, ChildWorker), for tests.
int children_started();

/// What a job in a child process calls to send a message to the parent while it runs (progress).
using ReportFn = std::function<void(const std::string& message)>;

/// Runs job(i, report) for i in [0, n) in forked child processes, at most `concurrent` at a time,
/// each on one thread, and returns the jobs' results in order. Separate processes, not threads,
/// because two single-threaded training loops in one process run no faster than one after another
/// on this machine (OpenMP's barriers and the shared address space's page faults), while two
/// processes run at nearly twice the speed. `on_report(i, message)` receives job i's messages on the
/// calling thread as they arrive. When a job throws, or a child dies, the other children are killed
/// and Error("<what>: job i: ...") is thrown; when on_report throws, the children are killed and its
/// exception goes on. Same rules for `job` as for read_in_child's `read`.
/// The children run at a lower priority (nice +4) than the caller.
std::vector<std::string> run_in_children(int n, int concurrent, const std::string& what,
                                         const std::function<std::string(int, const ReportFn&)>& job,
                                         const std::function<void(int, const std::string&)>& on_report = {});

/// A forked copy of this process that runs `task` each time the parent asks, on one thread, with
/// `shared_bytes` of memory mapped into both processes (each sees the other's writes): work split
/// between two processes step by step, such as half of each training minibatch (core/trainer.cpp).
/// The parent fills shared(), calls start(), does its own part and then wait(); the child's task
/// reads and writes only shared() to communicate. Made from one thread, outside any parallel region.
class ChildWorker {
 public:
  /// Throws Error("<what>: ...") when the memory cannot be mapped or the process not started.
  ChildWorker(const std::string& what, size_t shared_bytes, std::function<void(char* shared)> task);
  /// Ends the child (killed: between runs it holds nothing of its own) and waits for it.
  ~ChildWorker();
  ChildWorker(const ChildWorker&) = delete;
  ChildWorker& operator=(const ChildWorker&) = delete;

  char* shared() const { return shared_; }
  /// The child's process id (-1 once it has died).
  int pid() const { return pid_; }
  /// The child begins a run of its task.
  void start();
  /// Waits for the run start() began. Throws Error("<what>: ...") with the task's message when it threw,
  /// or when the child died (then every later start() and wait() throws too).
  void wait();

 private:
  std::string what_;
  char* shared_ = nullptr;
  size_t bytes_ = 0;
  int fd_ = -1;  // this end of the socket pair to the child
  int pid_ = -1;
  bool dead_ = false;
};

/// What a child process sends back (read_in_child, run_in_children), as bytes and back again:
/// numbers, arrays, strings and matrices, in the order they were put.
class Bytes {
 public:
  std::string out;
  template <typename T>
  void put(const T& v) { out.append(reinterpret_cast<const char*>(&v), sizeof v); }
  template <typename T>
  void put_all(const T* p, size_t n) {
    put<uint64_t>(n);
    if (n > 0) out.append(reinterpret_cast<const char*>(p), n * sizeof(T));
  }
  void put_string(const std::string& s) { put_all(s.data(), s.size()); }
  void put_mat(const Mat& m) {
    put<int64_t>(m.rows());
    put<int64_t>(m.cols());
    if (m.size() > 0) out.append(reinterpret_cast<const char*>(m.data()), static_cast<size_t>(m.size()) * sizeof(float));
  }

  /// Reading `in`; a read past its end throws Error("<from> sent a short message").
  explicit Bytes(std::string in = {}, std::string from = "a child process") : in_(std::move(in)), from_(std::move(from)) {}
  template <typename T>
  T get() {
    T v;
    take(&v, sizeof v);
    return v;
  }
  template <typename T>
  std::vector<T> get_all() {
    std::vector<T> v(get<uint64_t>());
    take(v.data(), v.size() * sizeof(T));
    return v;
  }
  std::string get_string() {
    const std::vector<char> v = get_all<char>();
    return std::string(v.begin(), v.end());
  }
  Mat get_mat() {
    const auto rows = get<int64_t>(), cols = get<int64_t>();
    Mat m(rows, cols);
    take(m.data(), static_cast<size_t>(m.size()) * sizeof(float));
    return m;
  }

 private:
  void take(void* p, size_t n) {
    if (n == 0) return;  // (an empty vector's data() may be null, which memcpy may not be given)
    if (n > in_.size() - pos_) throw Error(from_ + " sent a short message");
    std::memcpy(p, in_.data() + pos_, n);
    pos_ += n;
  }
  std::string in_;
  std::string from_;
  size_t pos_ = 0;
};


}  // namespace dd
