// Section 12: the bone the replay removed, per sample: its depth map and class map, inline
// as PNG (and the depth map beside the report as removed_<i>.png).
#include "bone_image.hpp"
#include "burrbench/data_schema/atomic_file.hpp"
#include "report_page.hpp"

namespace burrbench::analysis {

std::string removed_bone_section(const ReportPage& page) {
  std::string b = "<h2 id=\"bone\">12. Removed bone</h2><p class=\"muted\">Depth map: thickness of bone "
                  "removed by the replay in each (x, y) column of the volume (plan view, y up).</p>";
  const auto& samples = page.in.samples;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const SampleInfo& s = samples[i];
    const auto png = render_removed_depth_png(s);
    if (png.empty()) {
      b += "<p>" + esc(s.id) + ": no depth map recorded.</p>";
      continue;
    }
    data_schema::write_file_atomic(page.out_dir / fmt::format("removed_{}.png", i),
                                   std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
    b += "<h3>" + esc(s.id) + "</h3><img class=\"bone\" alt=\"removed bone depth map\" src=\"data:image/png;base64," +
         base64(png) + "\">";
    const auto classes = render_removed_class_png(s);
    if (!classes.empty())
      b += "<p class=\"muted\">Bone class removed: per column, the class of most removed bone.</p>"
           "<img class=\"bone\" alt=\"removed bone class map\" src=\"data:image/png;base64," +
           base64(classes) + "\">";
  }
  return b;
}

}  // namespace burrbench::analysis
