// The report as a reader gets it: `burrbench report` on a directory whose prediction.h5 the
// real writer wrote, then loaded in headless Chromium (tests/analysis/browser_check.py); and
// report_data, the report's view of a prediction, against the data it was made from.
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
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/prediction.hpp"

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
  in.recordings[1].id = std::string("R2 ") + kImg;  // ids hold no '/' (HDF5 group names)
  in.samples[0].id = std::string("S1 ") + kImg;
  in.limitations.push_back(kScript);
  const auto dir = burrbench::testing::temp_dir("report");
  burrbench::data_schema::write_prediction(dir / "prediction.h5", burrbench::testing::prediction_of(in));
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
  for (const char* f : {"residuals.csv", "metrics.json", "removed_0.png"})
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
  EXPECT_NE(r.out.find("prediction.h5"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("rerun `burrbench validate`"), std::string::npos) << r.out;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << "one line: " << r.out;
  // An analysis directory of the older format (analysis.json): the same one line.
  std::ofstream(dir / "empty" / "analysis.json") << "{}\n";  // its presence marks the older format
  r = run(cli() + " report " + (dir / "empty").string() + " --out " + (dir / "rep" / "r.html").string());
  EXPECT_EQ(r.rc, 2) << r.out;
  EXPECT_NE(r.out.find("rerun `burrbench validate`"), std::string::npos) << r.out;
  burrbench::data_schema::write_prediction(dir / "prediction.h5", burrbench::testing::prediction_of(burrbench::testing::small_input()));
  r = run(cli() + " report " + dir.string() + " --out " + (dir / "rep" / "r.html").string() + " --assets " +
          (dir / "no-assets").string());
  EXPECT_EQ(r.rc, 2) << r.out;
  EXPECT_NE(r.out.find("template.html"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir / "rep")) << "nothing written, no folder left behind";
}

// The report's view of a prediction gives back, field by field, the data it was made from
// (the fixture's inverse, prediction_of, written the way validate writes its context).
TEST(ReportData, FromThePredictionAndItsContext) {
  const auto data = burrbench::testing::small_input();
  ReportInputs in;
  in.prediction = burrbench::testing::prediction_of(data);
  in.prediction_file = "p.h5";
  const ReportData back = report_data(in);
  EXPECT_EQ(back.mode, data.mode);
  EXPECT_EQ(back.experiment_name, data.experiment_name);
  EXPECT_EQ(back.limitations, data.limitations);
  ASSERT_EQ(back.recordings.size(), data.recordings.size());
  for (std::size_t i = 0; i < data.recordings.size(); ++i) {
    const auto &a = back.recordings[i], &b = data.recordings[i];
    EXPECT_EQ(a.id, b.id);
    EXPECT_EQ(a.role, b.role);
    EXPECT_EQ(a.t_s, b.t_s);
    EXPECT_EQ(a.measured_N, b.measured_N);
    EXPECT_EQ(a.predicted_N, b.predicted_N);
    EXPECT_EQ(a.used, b.used);
    ASSERT_EQ(a.segments.size(), b.segments.size());
    for (std::size_t k = 0; k < a.segments.size(); ++k) EXPECT_EQ(a.segments[k].label, b.segments[k].label);
  }
  ASSERT_EQ(back.samples.size(), 1u);
  EXPECT_EQ(back.samples[0].removed_depth_mm, data.samples[0].removed_depth_mm);
  EXPECT_EQ(back.samples[0].classes, data.samples[0].classes);
  // A recording whose samples count in both roles is shown once per role.
  auto& r = in.prediction.recordings[0];
  for (std::size_t k = 0; k < r.samples(); ++k) (k < 100 ? r.used_calibrate : r.used_validate)[k] = 1;
  for (std::size_t k = 0; k < r.samples(); ++k) (k < 100 ? r.used_validate : r.used_calibrate)[k] = 0;
  in.prediction.context["recordings"]["R1"]["segments"][1]["role"] = "validate";
  const ReportData split = report_data(in);
  ASSERT_EQ(split.recordings.size(), 3u);
  EXPECT_EQ(split.recordings[1].id, "R1@validate");
  EXPECT_EQ(split.recordings[1].segments.at(0).label, "sweep");
  EXPECT_EQ(split.recordings[0].segments.at(0).label, "plunge");
  // A context that lacks a recording of the prediction names the file and the field.
  in.prediction.context["recordings"].erase("R2");
  try {
    (void)report_data(in);
    FAIL() << "no error";
  } catch (const burrbench::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("recordings.R2"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("p.h5"), std::string::npos) << e.what();
  }
}
