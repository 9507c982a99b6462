#include "core/progress.h"

#include <unistd.h>

#include <cmath>

namespace dd {

std::string format_duration(double seconds) {
  char buf[32];
  if (!std::isfinite(seconds) || seconds < 0) return "?";
  if (seconds < 60) {
    std::snprintf(buf, sizeof buf, "%.1fs", seconds);
  } else if (seconds < 3600) {
    std::snprintf(buf, sizeof buf, "%dm%02ds", static_cast<int>(seconds) / 60, static_cast<int>(seconds) % 60);
  } else {
    std::snprintf(buf, sizeof buf, "%dh%02dm", static_cast<int>(seconds) / 3600,
                  (static_cast<int>(seconds) % 3600) / 60);
  }
  return buf;
}

double time_left(double elapsed, int base, int done, int total) {
  return done > base ? elapsed * (total - done) / (done - base) : NAN;
}

ProgressBar::ProgressBar(std::string label, std::string value_name, std::FILE* out)
    : label_(std::move(label)),
      value_name_(std::move(value_name)),
      out_(out),
      tty_(isatty(fileno(out)) != 0),
      start_(std::chrono::steady_clock::now()),
      part_start_(start_),
      last_draw_(start_) {}

ProgressBar::~ProgressBar() { finish(); }

void ProgressBar::update(int done, int total, double value) {
  const auto now = std::chrono::steady_clock::now();
  if (total_ > 0 && (total != total_ || done < done_)) {
    if (!tty_) draw(false);  // the last part's end, before the count restarts
    ++part_;
    part_start_ = now;
    base_ = 0;
  }
  done_ = done;
  total_ = total;
  value_ = value;
  const double since = std::chrono::duration<double>(now - last_draw_).count();
  if (since >= (tty_ ? 0.1 : every_s_)) {
    last_draw_ = now;
    draw(false);
  }
}

void ProgressBar::finish() {
  if (finished_) return;
  finished_ = true;
  if (total_ > 0) draw(true);
}

ProgressFn ProgressBar::fn() {
  return [this](int done, int total, double value) { update(done, total, value); };
}

void ProgressBar::draw(bool final) {
  const auto now = std::chrono::steady_clock::now();
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double frac = total_ > 0 ? static_cast<double>(done_) / total_ : 0.0;
  const double left = time_left(std::chrono::duration<double>(now - part_start_).count(), base_, done_, total_);
  const std::string label = part_ > 1 ? label_ + ", part " + std::to_string(part_) : label_;
  // (no value to show, e.g. while counting members that have sampled: NaN)
  const std::string value = value_name_.empty() || std::isnan(value_) ? "" : "  " + value_name_ + " " + [&] {
    char b[32];
    std::snprintf(b, sizeof b, "%.4g", value_);
    return std::string(b);
  }();
  if (tty_) {
    constexpr int kWidth = 28;
    const int filled = static_cast<int>(frac * kWidth);
    std::string bar(static_cast<size_t>(filled), '#');
    bar.resize(kWidth, '.');
    std::fprintf(out_, "\r%s [%s] %d/%d%s  %s %s\033[K", label.c_str(), bar.c_str(), done_, total_,
                 value.c_str(), final ? "took" : "left",
                 format_duration(final ? elapsed : left).c_str());
    if (final) std::fputc('\n', out_);
  } else {
    std::fprintf(out_, "%s %d/%d (%3.0f%%)%s  %s %s\n", label.c_str(), done_, total_, 100 * frac,
                 value.c_str(), final ? "took" : "left",
                 format_duration(final ? elapsed : left).c_str());
  }
  std::fflush(out_);
}

}  // namespace dd
