// The report's assets (template, styles, report.js, uPlot inlined) and the page filled
// into the template.
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "burrbench/data_schema/error.hpp"
#include "report_page.hpp"

namespace burrbench::analysis {
namespace fs = std::filesystem;

namespace {

std::string read_text(const fs::path& p, const std::string& what) {
  std::ifstream f(p, std::ios::binary);
  if (!f)
    throw InputError(p.string(), "file", what + " (report assets: see docs/report.md)", "cannot open");
  std::ostringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// The library's licence header names its home page; no http(s) reference may remain in
// a report that must open offline, so the scheme is dropped (the text stays).
std::string strip_url_schemes(std::string s) {
  for (const std::string scheme : {"https://", "http://"})
    for (auto pos = s.find(scheme); pos != std::string::npos; pos = s.find(scheme, pos))
      s.erase(pos, scheme.size());
  return s;
}

void replace_once(std::string& s, const std::string& key, const std::string& value) {
  const auto pos = s.find(key);
  if (pos == std::string::npos)
    throw InputError("template.html", key, "the placeholder in the report template", "missing");
  s.replace(pos, key.size(), value);
}

}  // namespace

fs::path default_assets_dir() {
  if (const char* env = std::getenv("BURRBENCH_REPORT_ASSETS"); env && *env) return env;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = exe.parent_path().parent_path() / "share" / "burrbench" / "report";
    if (fs::exists(installed / "node_modules", ec)) return installed;
  }
  // This file lives at <source>/analysis/src/report_assets.cpp (CMake passes absolute paths).
  return fs::path(__FILE__).parent_path().parent_path() / "report";
}

ReportAssets load_assets(const ReportOptions& opt) {
  ReportAssets a;
  a.dir = opt.assets_dir.empty() ? default_assets_dir() : opt.assets_dir;
  a.tmpl = read_text(a.dir / "template.html", "template.html");
  a.css = read_text(a.dir / "report.css", "report.css") + "\n" +
          read_text(a.dir / "node_modules/uplot/dist/uPlot.min.css", "uPlot CSS (npm ci)");
  a.js = strip_url_schemes(read_text(a.dir / "node_modules/uplot/dist/uPlot.iife.min.js", "uPlot (npm ci)")) + "\n" +
         read_text(a.dir / "report.js", "report.js");
  return a;
}

std::string fill_template(const ReportAssets& assets, const std::string& title, const std::string& body,
                          const nlohmann::json& data) {
  std::string html = assets.tmpl;
  replace_once(html, "<!--BURRBENCH:TITLE-->", html::esc(title));
  replace_once(html, "<!--BURRBENCH:CSS-->", assets.css);
  replace_once(html, "<!--BURRBENCH:BODY-->", body);
  replace_once(html, "<!--BURRBENCH:DATA-->", json_for_script(data));
  replace_once(html, "<!--BURRBENCH:JS-->", assets.js);
  return html;
}

}  // namespace burrbench::analysis
