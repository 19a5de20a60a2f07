#include "burrbench/data_schema/progress.hpp"

#include <unistd.h>

#include <fmt/format.h>

namespace burrbench {

TerminalProgress::TerminalProgress(std::string label, std::FILE* out)
    : label_(std::move(label)), out_(out), tty_(isatty(fileno(out)) != 0) {
  start_ = last_ = std::chrono::steady_clock::now();
}

double TerminalProgress::elapsed_s(std::chrono::steady_clock::time_point now) const {
  return std::chrono::duration<double>(now - start_).count();
}

std::string remaining_time(double fraction, double elapsed_s) {
  // Below 2 % done or 1 s in, the rate is too uncertain to extrapolate.
  if (!(fraction >= 0.02 && fraction < 1) || elapsed_s < 1) return "";
  const double left = elapsed_s * (1 - fraction) / fraction;
  if (left < 90) return fmt::format(", ~{:.0f} s left", left);
  return fmt::format(", ~{:.0f} min left", left / 60);
}

void TerminalProgress::update(double fraction, const std::string& line) {
  const auto now = std::chrono::steady_clock::now();
  const auto every = tty_ ? std::chrono::milliseconds(100) : std::chrono::milliseconds(5000);
  if (printed_ && now - last_ < every) return;
  last_ = now;
  printed_ = true;
  std::string pct = fraction >= 0 ? fmt::format("{:5.1f}% ", 100.0 * fraction) : std::string();
  const std::string who = stage_.empty() ? label_ : fmt::format("{} [{}]", label_, stage_);
  const double el = elapsed_s(now);
  std::string text = fmt::format("{}: {}{} [{:.1f} s{}]", who, pct, line, el, remaining_time(fraction, el));
  if (tty_) {
    fmt::print(out_, "\r\033[K{}", text);
  } else {
    fmt::print(out_, "{}\n", text);
  }
  std::fflush(out_);
}

void TerminalProgress::stage(const std::string& name, const std::string& detail) {
  stage_ = name;
  kept_line(stage_line(name, detail));
}

void TerminalProgress::note(const std::string& line) { kept_line(line); }

void TerminalProgress::kept_line(const std::string& line) {
  const auto now = std::chrono::steady_clock::now();
  // On a terminal the line stays (newline) and the status line goes on below it.
  fmt::print(out_, "{}{}: {} [{:.1f} s]\n", tty_ && printed_ ? "\r\033[K" : "", label_, line, elapsed_s(now));
  std::fflush(out_);
  last_ = now;
  printed_ = false;  // the next update is shown at once, below it
}

void TerminalProgress::finish(const std::string& summary_line) {
  const auto now = std::chrono::steady_clock::now();
  if (tty_ && printed_) fmt::print(out_, "\r\033[K");
  fmt::print(out_, "{}: {} [{:.1f} s]\n", label_, summary_line, elapsed_s(now));
  std::fflush(out_);
}

}  // namespace burrbench
