#pragma once
// The whole calibration's fraction done, for the caller's progress sink (internal). The
// stages report iterations and starts without a fraction (a solve's iteration limit says
// little of its end); this sink between them and the caller's gives every line the share
// of the run's replays done, done / (done + still planned), with each stage's replays
// planned from the options and the experiment (planned_replays). A stage that needs more
// than planned keeps the fraction rising, slower; one that needs fewer moves it on at its
// end; a repeat (ReplayPlan::repeats) adds to the plan, and holds the fraction until the
// work catches up. Shown values never fall and reach 1 only at complete().
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <set>
#include <string>

#include "burrbench/data_schema/progress.hpp"

namespace burrbench::calibration::detail {

struct Run;

// Each pipeline stage's replays (calibrate.cpp's stage names), estimated once the
// recordings are selected: a solve costs about its iterations plus three evaluations, each
// a replay of every recording (docs/calibration.md "Progress").
struct ReplayPlan {
  std::map<std::string, double> stages;  // pipeline stage → replays
  // A stage line that starts work the plan could not foresee → the replays it adds to the
  // pipeline stage it comes in ("refit": a profile found a cheaper point, and the refine
  // and the profiles run again).
  std::map<std::string, double> repeats;
};
ReplayPlan planned_replays(const Run& run);

class OverallProgress final : public Progress {
 public:
  // `inner`: the caller's sink (the stages see this one only when it is not null);
  // `replays`: the run's replays so far.
  OverallProgress(Progress* inner, std::function<std::uint64_t()> replays)
      : inner_(inner), replays_(std::move(replays)) {}
  void plan(ReplayPlan plan);
  void begin(const std::string& stage);  // a pipeline stage starts (after its predecessor ended)
  void end(const std::string& stage);
  void complete(const std::string& line);  // the whole run: fraction 1
  double fraction();                       // as the next line would show it

  void update(double, const std::string& line) override;
  void stage(const std::string& name, const std::string& detail) override;
  void stage_at(double, const std::string& name, const std::string& detail) override { stage(name, detail); }
  void finish(const std::string& line) override { inner_->finish(line); }
  void note(const std::string& line) override { inner_->note(line); }

 private:
  double fraction_locked();
  Progress* inner_;
  std::function<std::uint64_t()> replays_;
  std::mutex mu_;  // multistart reports from its worker threads
  std::map<std::string, double> planned_;
  std::map<std::string, double> repeats_;
  std::set<std::string> ended_;
  std::string current_;
  std::uint64_t at_begin_ = 0;  // replays when the current stage began
  double shown_ = 0;
};

}  // namespace burrbench::calibration::detail
