// Section 3: the solution verification — the convergence study (validate) or the fit's
// discretization check (calibrate) — and its verdict as a badge for the top of the report.
#include <cmath>

#include "report_page.hpp"

namespace burrbench::analysis {

namespace {

// The convergence study (validate), or the calibration's discretization check (calibrate):
// whether the model's discretization error is below the sensor noise, in words first.
std::string verification_body(const ReportData& in, const json* fit) {
  std::string h;
  const json& v = in.verification;
  if (v.is_object() && v.contains("recordings")) {
    const bool known = v.contains("below_noise") && v.at("below_noise").is_boolean();
    const bool below = known && v.at("below_noise").get<bool>();
    h += fmt::format("<p id=\"verification-verdict\"><span class=\"verdict {}\">{}</span> {}.</p>",
                     !known ? "none" : below ? "pass" : "fail",
                     !known ? "NOISE UNKNOWN" : below ? "DISCRETIZATION ERROR BELOW NOISE" : "DISCRETIZATION ERROR ABOVE NOISE",
                     esc(v.value("verdict", std::string())));
    h += "<p class=\"muted\">Every recording replayed with the same constants at the sample's voxel size l, "
         "at l/2 (each voxel split into 8), at 2l (blocks of 8 merged) and at half the replay step. Change: "
         "RMS over the used samples and the three axes against (l, Δt), comparable with the per-axis sensor "
         "noise σ = " + (v.contains("sigma_N") && v.at("sigma_N").is_number() ? num(v.at("sigma_N").get<double>()) + " N"
                                                                              : std::string("unknown")) +
         " (" + esc(v.value("sigma_source", std::string())) + "). Error at l: Richardson from 2l, l, l/2 with the "
         "observed order (clamped to [0.5, 4]); the step's error assumes first order (docs/calibration.md).</p>";
    if (v.contains("reach") && v.at("reach").is_array() && !v.at("reach").empty()) {  // since the twentieth session
      std::vector<std::string> parts;
      auto dims = [](const json& d) {
        return d.is_array() && d.size() == 3 ? fmt::format("{}×{}×{}", d[0].dump(), d[1].dump(), d[2].dump()) : std::string("?");
      };
      for (const auto& r : v.at("reach"))
        parts.push_back(fmt::format("{} {} of its {} voxels", esc(r.value("sample", std::string())),
                                    dims(r.value("replayed_dims", json())), dims(r.value("dims", json()))));
      h += "<p class=\"muted\" id=\"verification-reach\">Replayed at every level: the part of each sample within "
           "reach of the burr (its radius and 4 voxels round every centre; the same figures as the whole sample to "
           "rounding): " + fmt::format("{}", fmt::join(parts, "; ")) + ".</p>";
    }
    std::vector<std::string> classes;
    h += "<div class=\"scroll\"><table><tr><th>recording</th><th>level</th><th>voxel (mm)</th><th>step (µs)</th>"
         "<th>RMS change (N)</th><th>largest change (N)</th><th>peak |F| (N)</th>";
    if (!v.at("recordings").empty())
      for (const auto& [name, _] : v.at("recordings")[0].at("levels")[0].at("removed_mm3").items()) {
        classes.push_back(name);
        h += "<th>removed " + esc(name) + " (mm³)</th>";
      }
    h += "</tr>";
    for (const auto& r : v.at("recordings")) {
      for (const auto& L : r.at("levels")) {
        h += "<tr>" + td(esc(r.value("id", std::string()))) + td(esc(L.value("level", std::string()))) +
             td(num(L.value("voxel_mm", NAN)), true) + td(num(L.value("step_us", NAN)), true) +
             td(num(L.value("rms_change_N", NAN)), true) + td(num(L.value("max_change_N", NAN)), true) +
             td(num(L.value("peak_N", NAN)), true);
        for (const auto& c : classes)
          h += td(num(L.at("removed_mm3").value(c, NAN), 5), true);
        h += "</tr>";
      }
      const auto& ord = r.at("voxel_order");
      h += "<tr class=\"total\">" + td(esc(r.value("id", std::string()))) + td("<b>error at l</b>") +
           td("order " + (ord.is_number() ? num(ord.get<double>(), 3) : std::string("not observed"))) +
           td("step " + num(r.value("step_error_N", NAN), 3) + " N") +
           td("<b>" + num(r.value("error_N", NAN), 3) + "</b>", true) + td("") + td("");
      for (const auto& c : classes)
        h += td("± " + num(r.at("removed_error").at(c).value("error_mm3", NAN), 3), true);
      h += "</tr>";
    }
    h += "</table></div>";
  } else if (fit && fit->contains("settings") && fit->at("settings").contains("discretization_check") &&
             fit->at("settings").at("discretization_check").value("computed", false)) {
    std::size_t limited = 0;
    for (const auto& p : fit->at("parameters"))
      limited += limited_by_discretization(p);
    h += fmt::format("<p>The calibration refitted every constant on the sample with its voxels merged by 2 "
                     "(voxel {} mm): <b>{} constant(s) limited by discretization error</b>, i.e. moved by more "
                     "than half their 95 % interval. Their intervals hold for the model at the fit's voxel "
                     "size; as physical constants read the widened interval (section 6, "
                     "docs/calibration.md). For the force, run <code>burrbench verify</code>.</p>",
                     num(fit->at("settings").at("discretization_check").value("coarse_voxel_mm", NAN)), limited);
  } else {
    h += "<p class=\"muted\">Not computed in this run (<code>validate --no-verification</code>, or a calibration "
         "with <code>--no-discretization-check</code>). <code>burrbench verify</code> makes the study.</p>";
  }
  return h;
}

}  // namespace

std::string verification_section(const ReportPage& page) {
  return "<h2 id=\"verif\">3. Solution verification</h2>" + verification_body(page.in, page.fit_or_null());
}

// The verification's verdict in one badge and a clause, for the top of the report beside
// the gate: the convergence study's (validate), else the fit's discretization check.
std::string verification_badge(const ReportData& in, const json* fit) {
  const json& v = in.verification;
  if (v.is_object() && v.contains("recordings")) {
    const bool known = v.contains("below_noise") && v.at("below_noise").is_boolean();
    const bool below = known && v.at("below_noise").get<bool>();
    return fmt::format("<span class=\"verdict {}\" id=\"verification-badge\">{}</span>",
                       !known ? "none" : below ? "pass" : "fail",
                       !known ? "VERIFICATION: NOISE UNKNOWN"
                       : below ? "VERIFICATION: DISCRETIZATION ERROR BELOW NOISE"
                               : "VERIFICATION: DISCRETIZATION ERROR ABOVE NOISE");
  }
  if (fit && fit->contains("settings") && fit->at("settings").contains("discretization_check") &&
      fit->at("settings").at("discretization_check").value("computed", false)) {
    std::size_t n = 0;
    for (const auto& p : fit->at("parameters")) n += limited_by_discretization(p);
    // Grey when none is limited: the fit's check speaks of the constants, not of the force's
    // discretization error against the noise (only the convergence study does).
    return fmt::format("<span class=\"verdict {}\" id=\"verification-badge\">CONVERGENCE STUDY NOT RUN · FIT'S "
                       "DISCRETIZATION CHECK: {}</span>",
                       n ? "fail" : "none", n ? fmt::format("{} CONSTANT(S) LIMITED", n) : std::string("NO CONSTANT LIMITED"));
  }
  return "<span class=\"verdict none\" id=\"verification-badge\">VERIFICATION NOT COMPUTED</span>";
}

}  // namespace burrbench::analysis
