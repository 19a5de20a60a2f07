// The page's files: the watch's own (watch/page) and uPlot from the report's assets, so
// the page draws with the same uPlot build the report inlines (docs/report.md).
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "burrbench/analysis/report.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/watch/session.hpp"

namespace burrbench::watch {
namespace fs = std::filesystem;

namespace {

fs::path page_dir() {
  if (const char* env = std::getenv("BURRBENCH_WATCH_PAGE"); env && *env) return env;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = exe.parent_path().parent_path() / "share" / "burrbench" / "watch";
    if (fs::exists(installed / "watch.html", ec)) return installed;
  }
  return BURRBENCH_WATCH_PAGE_DIR;
}

std::string read_text(const fs::path& p, const std::string& what) {
  std::ifstream f(p, std::ios::binary);
  if (!f) throw InputError(p.string(), "file", what + " (docs/watch.md)", "cannot open");
  std::ostringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

void fill(std::string& s, const std::string& key, const std::string& value) {
  const auto pos = s.find(key);
  if (pos == std::string::npos)
    throw InputError("watch.html", key, "the placeholder in the watch page", "missing");
  s.replace(pos, key.size(), value);
}

}  // namespace

std::string watch_page_html() {
  const fs::path dir = page_dir();
  const fs::path uplot = analysis::default_assets_dir() / "node_modules" / "uplot" / "dist";
  std::string html = read_text(dir / "watch.html", "the watch page");
  fill(html, "/*BURRBENCH:UPLOT_CSS*/",
       read_text(uplot / "uPlot.min.css", "uPlot CSS (npm ci in analysis/report)"));
  fill(html, "/*BURRBENCH:UPLOT_JS*/",
       read_text(uplot / "uPlot.iife.min.js", "uPlot (npm ci in analysis/report)"));
  fill(html, "/*BURRBENCH:WATCH_JS*/", read_text(dir / "watch.js", "the watch page's script"));
  return html;
}

}  // namespace burrbench::watch
