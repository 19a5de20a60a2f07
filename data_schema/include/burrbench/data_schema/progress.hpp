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
  // A long operation's next stage ("refine", "profiles"): what the updates after it belong
  // to. `detail` says what the stage does. By default an ordinary update.
  virtual void stage(const std::string& name, const std::string& detail) { update(-1, stage_line(name, detail)); }
  // The same when `fraction` of the whole operation is done (< 0: not known): a sink that
  // passes fractions on (the Python callback) takes it; by default the stage alone.
  virtual void stage_at(double fraction, const std::string& name, const std::string& detail) {
    (void)fraction;
    stage(name, detail);
  }
  virtual void finish(const std::string& summary_line) = 0;
  // Something the user must see now (a device that stopped measuring): a line of its own,
  // kept, whatever the update rate; the stage does not change. By default an update.
  virtual void note(const std::string& line) { update(-1, line); }
  // A stage's line: "refine: the best point so far to convergence" ("profiles" alone).
  static std::string stage_line(const std::string& name, const std::string& detail) {
    return detail.empty() ? name : name + ": " + detail;
  }
};

// ", ~17 s left" (", ~4 min left" from 90 s): the time still to go at the rate so far,
// for a status line at `fraction` done after `elapsed_s`; "" while too early to tell.
std::string remaining_time(double fraction, double elapsed_s);

// Rewrites one status line on a terminal (stderr) at most every 100 ms; when stderr is
// not a terminal it prints a plain line at most every 5 s so logs stay readable. A stage
// is never dropped by that limit: it gets a line of its own (kept on a terminal, above the
// status line), and the updates after it name it ("calibrate [refine]: iter 3 …"), so a
// glance at the screen or the log tells which fit an iteration belongs to. An update with a
// fraction shows it as a percentage and the time left (remaining_time).
class TerminalProgress final : public Progress {
 public:
  explicit TerminalProgress(std::string label, std::FILE* out = stderr);
  void update(double fraction, const std::string& line) override;
  void stage(const std::string& name, const std::string& detail) override;
  void finish(const std::string& summary_line) override;
  void note(const std::string& line) override;

 private:
  double elapsed_s(std::chrono::steady_clock::time_point now) const;
  void kept_line(const std::string& line);  // a line that stays above the status line
  std::string label_;
  std::string stage_;  // the current stage's name ("" before the first)
  std::FILE* out_;
  bool tty_;
  std::chrono::steady_clock::time_point start_, last_;
  bool printed_ = false;
};

}  // namespace burrbench
