// Progress reporting for long work (training, calibration, evaluation).
//
// On a terminal it redraws one line with a bar, the step count, a value (the loss) and the time
// left; when the output is a pipe or a file it prints a plain line every few seconds instead.
// Hand-written: Debian 12 packages no C++ progress-bar library.
#pragma once

#include <chrono>
#include <cstdio>
#include <functional>
#include <string>

namespace dd {

/// Called with (done, total, value) as work advances; value is e.g. the running loss.
using ProgressFn = std::function<void(int done, int total, double value)>;

class ProgressBar {
 public:
  /// `label` starts the line; `value_name` names the value (e.g. "loss"); output goes to `out`.
  ProgressBar(std::string label, std::string value_name, std::FILE* out = stderr);
  ~ProgressBar();

  /// Records progress; redraws at most ~10 times a second on a terminal, every 5 s otherwise. A
  /// count that goes back or a new total starts the next part of the work ("part 2"): its time
  /// left is estimated from that part alone.
  void update(int done, int total, double value);
  /// Prints the final state and a newline (once).
  void finish();
  /// A ProgressFn that forwards to this bar.
  ProgressFn fn();
  /// Work resumed with `done` units already done before this bar started: the time left is
  /// estimated from the rate since then, not from `done` units in no time.
  void resume_from(int done) { base_ = done; }
  /// Plain lines, one every `every_s` seconds, even on a terminal: for long work beside other
  /// output (eval's cells), where a redrawn bar would fight with its neighbours' lines.
  ProgressBar& lines_every(double every_s) {
    tty_ = false;
    every_s_ = every_s;
    return *this;
  }

 private:
  void draw(bool final);

  std::string label_, value_name_;
  std::FILE* out_;
  bool tty_;
  bool finished_ = false;
  int done_ = 0, total_ = 0, base_ = 0;
  double value_ = 0.0, every_s_ = 5.0;
  int part_ = 1;  // work in parts (training, then the threshold): the count restarts with each
  std::chrono::steady_clock::time_point start_, part_start_, last_draw_;
};

/// Seconds left at the rate seen so far: `elapsed` seconds went to the units from `base` (done before
/// the bar started) to `done`, of `total`. NaN before the first fresh unit.
double time_left(double elapsed, int base, int done, int total);

/// Formats seconds as "1m05s" / "12.3s".
std::string format_duration(double seconds);

}  // namespace dd
