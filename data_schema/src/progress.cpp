#include "burrbench/data_schema/progress.hpp"

#include <unistd.h>

#include <fmt/format.h>

namespace burrbench {

TerminalProgress::TerminalProgress(std::string label, std::FILE* out)
    : label_(std::move(label)), out_(out), tty_(isatty(fileno(out)) != 0) {
  start_ = last_ = std::chrono::steady_clock::now();
}

void TerminalProgress::update(double fraction, const std::string& line) {
  const auto now = std::chrono::steady_clock::now();
  const auto every = tty_ ? std::chrono::milliseconds(100) : std::chrono::milliseconds(5000);
  if (printed_ && now - last_ < every) return;
  last_ = now;
  printed_ = true;
  const double elapsed_s = std::chrono::duration<double>(now - start_).count();
  std::string pct = fraction >= 0 ? fmt::format("{:5.1f}% ", 100.0 * fraction) : std::string();
  std::string text = fmt::format("{}: {}{} [{:.1f} s]", label_, pct, line, elapsed_s);
  if (tty_) {
    fmt::print(out_, "\r\033[K{}", text);
  } else {
    fmt::print(out_, "{}\n", text);
  }
  std::fflush(out_);
}

void TerminalProgress::finish(const std::string& summary_line) {
  const double elapsed_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  if (tty_ && printed_) fmt::print(out_, "\r\033[K");
  fmt::print(out_, "{}: {} [{:.1f} s]\n", label_, summary_line, elapsed_s);
  std::fflush(out_);
}

}  // namespace burrbench
