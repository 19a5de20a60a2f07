// TerminalProgress into a log (not a terminal): updates are thinned to one line per 5 s,
// but a stage always gets its line and names the updates after it, so a log of a long
// calibration tells which fit each iteration belongs to.
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "burrbench/data_schema/progress.hpp"

namespace {

// Everything written to `f` so far, as lines.
std::vector<std::string> lines_of(std::FILE* f) {
  std::fflush(f);
  std::rewind(f);
  std::string all;
  char buf[512];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, f)) > 0;) all.append(buf, n);
  std::vector<std::string> out;
  std::istringstream in(all);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

bool starts_with(const std::string& s, const std::string& p) { return s.rfind(p, 0) == 0; }

}  // namespace

TEST(Progress, AStageIsNeverThinnedOutAndNamesTheUpdatesAfterIt) {
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  burrbench::TerminalProgress p("calibrate", f);
  p.update(-1, "first");
  p.update(-1, "thinned out");  // within 5 s of the first: dropped
  p.stage("refine", "the best start to convergence");
  p.update(0.5, "iter 1");  // the first update of a stage is shown at once
  p.update(0.6, "iter 2");  // then thinned again
  p.stage("profiles", "");
  p.finish("done");
  const auto l = lines_of(f);
  std::fclose(f);
  ASSERT_EQ(l.size(), 5u) << ::testing::PrintToString(l);
  EXPECT_TRUE(starts_with(l[0], "calibrate: first [")) << l[0];
  EXPECT_TRUE(starts_with(l[1], "calibrate: refine: the best start to convergence [")) << l[1];
  EXPECT_TRUE(starts_with(l[2], "calibrate [refine]:  50.0% iter 1 [")) << l[2];
  EXPECT_TRUE(starts_with(l[3], "calibrate: profiles [")) << l[3];
  EXPECT_TRUE(starts_with(l[4], "calibrate: done [")) << l[4];
}

// A sink that only knows update() still sees every stage, as an update.
TEST(Progress, TheDefaultStageIsAnUpdate) {
  struct Lines final : burrbench::Progress {
    std::vector<std::string> seen;
    void update(double, const std::string& line) override { seen.push_back(line); }
    void finish(const std::string&) override {}
  } sink;
  burrbench::Progress& p = sink;
  p.stage("refine", "the best start to convergence");
  p.stage("profiles", "");
  EXPECT_EQ(sink.seen, (std::vector<std::string>{"refine: the best start to convergence", "profiles"}));
}

// The time left is the rate so far extrapolated: none too early to tell or once done,
// seconds below 90 s, minutes above.
TEST(Progress, TheTimeLeftFollowsTheRateSoFar) {
  EXPECT_EQ(burrbench::remaining_time(0.25, 10), ", ~30 s left");
  EXPECT_EQ(burrbench::remaining_time(0.1, 60), ", ~9 min left");
  EXPECT_EQ(burrbench::remaining_time(0.01, 60), "");  // 1 %: too early
  EXPECT_EQ(burrbench::remaining_time(0.5, 0.5), "");  // half a second in: too early
  EXPECT_EQ(burrbench::remaining_time(1.0, 60), "");
  EXPECT_EQ(burrbench::remaining_time(-1, 60), "");    // no fraction
}
