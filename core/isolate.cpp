#include "core/isolate.h"

#include <signal.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>

#include "core/config.h"

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#include <sanitizer/common_interface_defs.h>
#define DD_HAVE_SANITIZER_HOOKS 1
#endif
#endif

// OpenMP's pool does not survive fork: the child runs on one thread. (Weak: a program without
// OpenMP has none to set.)
extern "C" void omp_set_num_threads(int) __attribute__((weak));

namespace dd {
namespace {

std::atomic<int> g_crashed{0};

// In the child: die plainly on a crash, so that only the parent reports (a fuzzer's or a sanitizer's
// crash handler would otherwise treat the child's death as the whole program's).
void child_setup() {
  for (const int sig : {SIGSEGV, SIGBUS, SIGABRT, SIGILL, SIGFPE}) ::signal(sig, SIG_DFL);
#ifdef DD_HAVE_SANITIZER_HOOKS
  __sanitizer_set_death_callback(nullptr);
#endif
  if (omp_set_num_threads) omp_set_num_threads(1);
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

std::string read_in_child(const std::string& path, const std::string& library, const std::function<std::string()>& read) {
  // tests/fuzz/run.sh --deep: in process, so that the fuzzer sees the reading code's coverage (and
  // libFuzzer's fork mode survives the libraries' crashes)
  static const bool in_process = std::getenv("DD_READ_IN_PROCESS") != nullptr;
  if (in_process) return read();
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
  std::string got;
  char buf[1 << 16];
  for (;;) {
    const ssize_t r = ::read(fds[0], buf, sizeof buf);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) break;
    got.append(buf, static_cast<size_t>(r));
  }
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  const bool clean = WIFEXITED(status) && WEXITSTATUS(status) == 0;
  if (clean && !got.empty() && got[0] == 'O') return got.substr(1);
  if (clean && !got.empty() && got[0] == 'E') throw Error(got.substr(1));
  ++g_crashed;
  const std::string how = WIFSIGNALED(status) ? "signal " + std::to_string(WTERMSIG(status)) + " (" + strsignal(WTERMSIG(status)) + ")"
                                              : "exit status " + std::to_string(WEXITSTATUS(status));
  throw Error(path + ": the file is corrupt: reading it crashed " + library + " (" + how + " in the child process that read it)");
}

}  // namespace dd
