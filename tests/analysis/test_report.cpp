// The report as a reader gets it: `burrbench report` on an analysis directory written by
// the real writer, then loaded in headless Chromium (tests/analysis/browser_check.py).
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "analysis/analysis_fixture.hpp"
#include "burrbench_cli.hpp"
#include "burrbench/analysis/report.hpp"

namespace fs = std::filesystem;
using namespace burrbench::analysis;

namespace {

struct Run {
  int rc;
  std::string out;
};

Run run(const std::string& cmd) {
  Run r{0, {}};
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  char buf[4096];
  while (std::size_t n = fread(buf, 1, sizeof buf, p)) r.out.append(buf, n);
  const int st = pclose(p);
  r.rc = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

std::string cli() { return burrbench::testing::burrbench_cli(); }

std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

std::size_t count(const std::string& s, const std::string& what) {
  std::size_t n = 0;
  for (auto pos = s.find(what); pos != std::string::npos; pos = s.find(what, pos + 1)) ++n;
  return n;
}

constexpr const char* kScript = "<script>document.title='PWNED'</script></script><!--";
constexpr const char* kImg = "<img src=x onerror=\"document.body.setAttribute('data-pwned','1')\">";

}  // namespace

TEST(Report, SelfContainedEscapedAndRendersInChromium) {
  auto in = burrbench::testing::small_input();
  in.experiment_name = std::string("exp ") + kScript;
  in.context_of_use = kImg;
  in.recordings[0].notes = std::string("notes ") + kScript + kImg;
  in.recordings[1].id = std::string("R2 ") + kScript;
  in.samples[0].id = std::string("S1 ") + kImg;
  in.limitations.push_back(kScript);
  const auto dir = burrbench::testing::temp_dir("report");
  write_analysis_input(dir, in);
  const auto out = dir / "out" / "report.html";
  const auto r = run(cli() + " report " + dir.string() + " --out " + out.string());
  ASSERT_EQ(r.rc, 0) << r.out;

  const std::string html = slurp(out);
  EXPECT_EQ(html.find("http://"), std::string::npos);
  EXPECT_EQ(html.find("https://"), std::string::npos);
  EXPECT_EQ(count(html, "<script"), 2u);   // the data block and the code, nothing injected
  EXPECT_EQ(count(html, "</script"), 2u);
  EXPECT_EQ(html.find("<img src=x"), std::string::npos);
  EXPECT_NE(html.find("&lt;script&gt;document.title=&#39;PWNED&#39;&lt;/script&gt;"), std::string::npos);
  EXPECT_NE(html.find("data:image/png;base64,"), std::string::npos);  // the removed-bone map
  for (const char* f : {"predictions.csv", "residuals.csv", "metrics.json", "removed_0.png"})
    EXPECT_TRUE(fs::exists(out.parent_path() / f)) << f;

  const auto b = run("/usr/bin/python3 " + std::string(BURRBENCH_SOURCE_DIR) +
                     "/tests/analysis/browser_check.py " + out.string() + " " + (dir / "chromium").string());
  ASSERT_EQ(b.rc, 0) << b.out;
  const auto j = nlohmann::json::parse(b.out.substr(b.out.find('{')));
  EXPECT_TRUE(j["console_errors"].empty()) << j["console_errors"].dump(1);
  const std::string dom = j["dom"];
  EXPECT_NE(dom.find("data-plots-done=\"1\""), std::string::npos) << "report.js did not finish";
  // Overview + 2 recordings × (force, residual vs time, residual vs prediction) + 2 histograms
  // + per role a QQ plot and an autocorrelation plot.
  EXPECT_EQ(count(dom, "data-rendered=\"1\""), 13u);
  EXPECT_EQ(count(dom, "<canvas"), 13u);
  EXPECT_FALSE(std::regex_search(dom, std::regex("<body[^>]*data-pwned")));
  EXPECT_EQ(dom.find("<title>PWNED</title>"), std::string::npos);
  EXPECT_NE(dom.find("ACCEPTANCE CRITERIA") == std::string::npos ? dom.find("No acceptance criteria") : 0,
            std::string::npos);
  // Plot lines are coloured; an empty page or blank plot areas are white/grey.
  EXPECT_GT(j["coloured_fraction"].get<double>(), 0.003) << j["screenshot"];
}

TEST(Report, BadInputsExitTwo) {
  const auto dir = burrbench::testing::temp_dir("report-bad");
  auto r = run(cli() + " report " + (dir / "nothing").string() + " --out " + (dir / "r.html").string());
  EXPECT_EQ(r.rc, 2) << r.out;
  EXPECT_NE(r.out.find("nothing"), std::string::npos) << r.out;
  fs::create_directories(dir / "empty");
  r = run(cli() + " report " + (dir / "empty").string() + " --out " + (dir / "rep" / "r.html").string());
  EXPECT_EQ(r.rc, 2) << r.out;
  EXPECT_NE(r.out.find("analysis.json"), std::string::npos) << r.out;
  write_analysis_input(dir, burrbench::testing::small_input());
  r = run(cli() + " report " + dir.string() + " --out " + (dir / "rep" / "r.html").string() + " --assets " +
          (dir / "no-assets").string());
  EXPECT_EQ(r.rc, 2) << r.out;
  EXPECT_NE(r.out.find("template.html"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir / "rep")) << "nothing written, no folder left behind";
}
