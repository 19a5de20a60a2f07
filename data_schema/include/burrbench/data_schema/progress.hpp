#pragma once
// Progress of long operations (acquire, replay, calibrate). Libraries report through a
// Progress sink; the CLI passes a TerminalProgress, tests pass nothing.
#include <chrono>
#include <cstdio>
#include <string>

namespace burrbench {

class Progress {
 public:
  virtual ~Progress() = default;
  // fraction in [0,1] or < 0 when unknown; line is a short status ("iter 4 cost 1.2e3").
  virtual void update(double fraction, const std::string& line) = 0;
  virtual void finish(const std::string& summary_line) = 0;
};

// Rewrites one status line on a terminal (stderr) at most every 100 ms; when stderr is
// not a terminal it prints a plain line at most every 5 s so logs stay readable.
class TerminalProgress final : public Progress {
 public:
  explicit TerminalProgress(std::string label, std::FILE* out = stderr);
  void update(double fraction, const std::string& line) override;
  void finish(const std::string& summary_line) override;

 private:
  std::string label_;
  std::FILE* out_;
  bool tty_;
  std::chrono::steady_clock::time_point start_, last_;
  bool printed_ = false;
};

}  // namespace burrbench
