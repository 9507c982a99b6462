#include "core/isolate.h"

#include <poll.h>
#include <signal.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <utility>

#include "core/config.h"
#include "core/runtime.h"

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#include <sanitizer/common_interface_defs.h>
#define DD_HAVE_SANITIZER_HOOKS 1
#endif
#endif

namespace dd {
namespace {

std::atomic<int> g_crashed{0};
std::atomic<int> g_started{0};

// In the child: die plainly on a crash, so that only the parent reports (a fuzzer's or a sanitizer's
// crash handler would otherwise treat the child's death as the whole program's).
void child_setup() {
  for (const int sig : {SIGSEGV, SIGBUS, SIGABRT, SIGILL, SIGFPE}) ::signal(sig, SIG_DFL);
#ifdef DD_HAVE_SANITIZER_HOOKS
  __sanitizer_set_death_callback(nullptr);
#endif
  set_openmp_threads(1);  // OpenMP's pool does not survive fork: the child runs on one thread
}

bool write_all(int fd, const char* p, size_t n) {
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return false;
    p += w;
    n -= static_cast<size_t>(w);
  }
  return true;
}

}  // namespace

int children_crashed() { return g_crashed.load(); }
int children_started() { return g_started.load(); }

namespace {

// A child that deadlocks at once (a lock that another thread of this process held at the fork stays
// held in the child: clang 14's ASan allocator takes none of its locks around fork, and libtorch's
// own locks are not fork-aware) would hang its reader forever. Such a child sleeps without using any
// CPU; one that reads or parses does not, and one waiting on a disk is in state D, not S.
constexpr int kPollMs = 500;
constexpr int kStalledPolls = 6;  // 3 s asleep without a clock tick of CPU
constexpr int kTries = 3;

// The process's CPU time so far in clock ticks and its state letter, from /proc/PID/stat.
std::pair<long long, char> cpu_and_state(pid_t pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/stat");
  const std::string s((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const size_t close = s.rfind(')');  // the command name in parentheses may hold spaces
  if (close == std::string::npos || close + 2 >= s.size()) return {-1, '?'};
  std::istringstream in(s.substr(close + 2));
  char state = '?';
  std::string skip;
  long long user = 0, system = 0;
  in >> state;
  for (int field = 4; field <= 13; ++field) in >> skip;
  in >> user >> system;
  return {user + system, state};
}

enum class Outcome { kFinished, kStalled };

// One child: forks, runs `read` in it, collects what it sends and its exit status.
Outcome read_once(const std::function<std::string()>& read, const std::string& path, std::string& got, int& status) {
  int fds[2];
  if (::pipe(fds) != 0) throw Error(path + ": could not create a pipe to read the file in a child process: " + strerror(errno));
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    throw Error(path + ": could not start a child process to read the file: " + strerror(errno));
  }
  if (pid == 0) {  // the child: read, send 'O' + result or 'E' + message, and leave without cleanup
    ::close(fds[0]);
    child_setup();
    std::string out;
    try {
      out = "O" + read();
    } catch (const std::exception& e) {
      out = std::string("E") + e.what();
    } catch (...) {
      out = "Eunknown error";
    }
    ::_exit(write_all(fds[1], out.data(), out.size()) ? 0 : 3);
  }
  ::close(fds[1]);
  got.clear();
  char buf[1 << 16];
  int asleep = 0;
  long long last_cpu = -1;
  Outcome outcome = Outcome::kFinished;
  for (;;) {
    pollfd p{fds[0], POLLIN, 0};
    const int ready = ::poll(&p, 1, kPollMs);
    if (ready < 0 && errno == EINTR) continue;
    if (ready == 0) {
      const auto [cpu, state] = cpu_and_state(pid);
      asleep = (state == 'S' && cpu == last_cpu) ? asleep + 1 : 0;
      last_cpu = cpu;
      if (asleep < kStalledPolls) continue;
      ::kill(pid, SIGKILL);
      outcome = Outcome::kStalled;
      break;
    }
    const ssize_t r = ::read(fds[0], buf, sizeof buf);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) break;
    got.append(buf, static_cast<size_t>(r));
    asleep = 0;
  }
  ::close(fds[0]);
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return outcome;
}

}  // namespace

std::string read_in_child(const std::string& path, const std::string& library, const std::function<std::string()>& read) {
  // tests/fuzz/run.sh --deep: in process, so that the fuzzer sees the reading code's coverage (and
  // libFuzzer's fork mode survives the libraries' crashes)
  static const bool in_process = std::getenv("DD_READ_IN_PROCESS") != nullptr;
  if (in_process) return read();
  std::string got;
  int status = 0;
  for (int attempt = 1;; ++attempt) {
    if (read_once(read, path, got, status) == Outcome::kFinished) break;
    if (attempt == kTries)
      throw Error(path + ": reading it with " + library + " stalled: the child process that read it slept for " +
                  std::to_string(kStalledPolls * kPollMs / 1000) + " s without progress, " + std::to_string(kTries) + " times");
  }
  const bool clean = WIFEXITED(status) && WEXITSTATUS(status) == 0;
  if (clean && !got.empty() && got[0] == 'O') return got.substr(1);
  if (clean && !got.empty() && got[0] == 'E') throw Error(got.substr(1));
  ++g_crashed;
  const std::string how = WIFSIGNALED(status) ? "signal " + std::to_string(WTERMSIG(status)) + " (" + strsignal(WTERMSIG(status)) + ")"
                                              : "exit status " + std::to_string(WEXITSTATUS(status));
  throw Error(path + ": the file is corrupt: reading it crashed " + library + " (" + how + " in the child process that read it)");
}

namespace {

// run_in_children's frames on a child's pipe: a type byte ('M' message, 'O' result, 'E' error),
// the payload's length (4 bytes, host order) and the payload.
bool write_frame(int fd, char type, const std::string& payload) {
  std::string frame(5, type);
  const uint32_t size = static_cast<uint32_t>(payload.size());
  std::memcpy(&frame[1], &size, 4);
  frame += payload;
  return write_all(fd, frame.data(), frame.size());
}

// The next whole frame in `buffer` from `pos`: its type and payload, `pos` moved past it; false when
// the frame there is not whole yet.
bool next_frame(const std::string& buffer, size_t& pos, char& type, std::string& payload) {
  if (buffer.size() - pos < 5) return false;
  uint32_t size = 0;
  std::memcpy(&size, &buffer[pos + 1], 4);
  if (buffer.size() - pos - 5 < size) return false;
  type = buffer[pos];
  payload = buffer.substr(pos + 5, size);
  pos += 5 + size;
  return true;
}

std::string describe_exit(int status) {
  if (WIFSIGNALED(status)) return "signal " + std::to_string(WTERMSIG(status)) + " (" + strsignal(WTERMSIG(status)) + ")";
  return "exit status " + std::to_string(WEXITSTATUS(status));
}

struct Child {
  int job = -1;
  pid_t pid = -1;
  int fd = -1;
  std::string buffer;  // bytes read and not yet parsed into frames
  bool done = false;   // its result ('O') arrived
};

}  // namespace

std::vector<std::string> run_in_children(int n, int concurrent, const std::string& what,
                                         const std::function<std::string(int, const ReportFn&)>& job,
                                         const std::function<void(int, const std::string&)>& on_report) {
  std::vector<std::string> results(static_cast<size_t>(std::max(n, 0)));
  std::vector<Child> running;
  int next = 0;
  auto kill_all = [&] {
    for (Child& c : running) {
      ::kill(c.pid, SIGKILL);
      ::close(c.fd);
      int status = 0;
      while (::waitpid(c.pid, &status, 0) < 0 && errno == EINTR) {
      }
    }
    running.clear();
  };
  auto fail = [&](const std::string& message) {
    kill_all();
    throw Error(what + ": " + message);
  };
  auto start = [&](int i) {
    int fds[2];
    if (::pipe(fds) != 0) fail(std::string("could not create a pipe for a child process: ") + strerror(errno));
    const pid_t pid = ::fork();
    if (pid < 0) {
      ::close(fds[0]);
      ::close(fds[1]);
      fail(std::string("could not start a child process: ") + strerror(errno));
    }
    if (pid == 0) {  // the child: run the job, send its messages and its result, leave without cleanup
      ::close(fds[0]);
      for (const Child& c : running) ::close(c.fd);
      child_setup();
      // Below the parent: more children than cores share them, and the parent's own threads (the
      // console's frames, a simulator) keep the priority they had.
      [[maybe_unused]] const int niceness = ::nice(4);
      const int fd = fds[1];
      const ReportFn report = [fd](const std::string& message) { write_frame(fd, 'M', message); };
      bool sent = false;
      try {
        sent = write_frame(fd, 'O', job(i, report));
      } catch (const std::exception& e) {
        sent = write_frame(fd, 'E', e.what());
      } catch (...) {
        sent = write_frame(fd, 'E', "unknown error");
      }
      ::_exit(sent ? 0 : 3);
    }
    ::close(fds[1]);
    ++g_started;
    Child c;
    c.job = i;
    c.pid = pid;
    c.fd = fds[0];
    running.push_back(std::move(c));
  };

  concurrent = std::max(concurrent, 1);
  while (next < n || !running.empty()) {
    while (next < n && static_cast<int>(running.size()) < concurrent) start(next++);
    std::vector<pollfd> polls;
    for (const Child& c : running) polls.push_back(pollfd{c.fd, POLLIN, 0});
    if (::poll(polls.data(), polls.size(), -1) < 0) {
      if (errno == EINTR) continue;
      fail(std::string("waiting for the child processes failed: ") + strerror(errno));
    }
    for (size_t k = 0; k < polls.size(); ++k) {
      if (!(polls[k].revents & (POLLIN | POLLHUP | POLLERR))) continue;
      Child& c = running[k];
      char buf[1 << 16];
      const ssize_t r = ::read(c.fd, buf, sizeof buf);
      if (r < 0 && errno == EINTR) continue;
      if (r > 0) {
        c.buffer.append(buf, static_cast<size_t>(r));
        // every whole frame in the buffer
        size_t pos = 0;
        char type = 0;
        std::string payload;
        while (next_frame(c.buffer, pos, type, payload)) {
          if (type == 'M') {
            if (on_report) {
              try {
                on_report(c.job, payload);
              } catch (...) {  // the caller gives up on the jobs: no child outlives this call
                kill_all();
                throw;
              }
            }
          } else if (type == 'O') {
            results[static_cast<size_t>(c.job)] = std::move(payload);
            c.done = true;
          } else {
            fail("job " + std::to_string(c.job) + ": " + payload);
          }
        }
        c.buffer.erase(0, pos);
        continue;
      }
      // end of file: the child has exited, or is about to
      int status = 0;
      while (::waitpid(c.pid, &status, 0) < 0 && errno == EINTR) {
      }
      ::close(c.fd);
      const Child ended = c;
      running.erase(running.begin() + static_cast<std::ptrdiff_t>(k));
      if (!ended.done || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
        fail("job " + std::to_string(ended.job) + ": the child process running it died (" + describe_exit(status) + ")");
      break;  // `running` changed: poll again
    }
  }
  return results;
}

ChildWorker::ChildWorker(const std::string& what, size_t shared_bytes, std::function<void(char*)> task)
    : what_(what), bytes_(std::max<size_t>(shared_bytes, 1)) {
  void* m = ::mmap(nullptr, bytes_, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  if (m == MAP_FAILED) throw Error(what_ + ": could not map " + std::to_string(bytes_) + " bytes of shared memory: " + strerror(errno));
  shared_ = static_cast<char*>(m);
  // one socket pair, both ways: the parent's send() to a dead child fails with EPIPE instead of
  // raising SIGPIPE
  int fds[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM, 0, fds) != 0) {
    ::munmap(shared_, bytes_);
    throw Error(what_ + ": could not create a socket pair: " + strerror(errno));
  }
  const pid_t pid = ::fork();
  if (pid < 0) {
    for (const int fd : fds) ::close(fd);
    ::munmap(shared_, bytes_);
    throw Error(what_ + ": could not start a child process: " + strerror(errno));
  }
  if (pid == 0) {  // the child: a run of the task per byte from the parent, an answer frame after each
    ::close(fds[0]);
    child_setup();
    char go = 0;
    for (;;) {
      ssize_t r;
      while ((r = ::read(fds[1], &go, 1)) < 0 && errno == EINTR) {
      }
      if (r != 1) ::_exit(0);  // the parent closed its end (or is gone)
      bool sent = false;
      try {
        task(shared_);
        sent = write_frame(fds[1], 'O', "");
      } catch (const std::exception& e) {
        sent = write_frame(fds[1], 'E', e.what());
      } catch (...) {
        sent = write_frame(fds[1], 'E', "unknown error");
      }
      if (!sent) ::_exit(3);
    }
  }
  ::close(fds[1]);
  ++g_started;
  fd_ = fds[0];
  pid_ = pid;
}

ChildWorker::~ChildWorker() {
  if (fd_ >= 0) ::close(fd_);
  if (pid_ > 0) {
    // Between runs the child only waits for the next: nothing of its own to lose. Killed rather than
    // left to see its socket close, which it would not when a child forked later holds a copy.
    ::kill(pid_, SIGKILL);
    int status = 0;
    while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
    }
  }
  if (shared_) ::munmap(shared_, bytes_);
}

void ChildWorker::start() {
  if (dead_) throw Error(what_ + ": its child process has died");
  const char go = 'G';
  ssize_t w;
  while ((w = ::send(fd_, &go, 1, MSG_NOSIGNAL)) < 0 && errno == EINTR) {
  }
  if (w != 1) {
    dead_ = true;
    throw Error(what_ + ": its child process has died (the pipe to it is closed)");
  }
}

void ChildWorker::wait() {
  if (dead_) throw Error(what_ + ": its child process has died");
  std::string buffer, payload;
  char type = 0, buf[4096];
  for (size_t pos = 0; !next_frame(buffer, pos, type, payload);) {
    const ssize_t r = ::read(fd_, buf, sizeof buf);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) {
      dead_ = true;
      int status = 0;
      while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
      }
      pid_ = -1;
      throw Error(what_ + ": its child process died (" + describe_exit(status) + ")");
    }
    buffer.append(buf, static_cast<size_t>(r));
  }
  if (type != 'O') throw Error(what_ + ": " + payload);
}

}  // namespace dd
