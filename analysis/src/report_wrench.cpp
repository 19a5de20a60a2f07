#include "report_wrench.hpp"

#include <cmath>

#include "report_html.hpp"

namespace burrbench::analysis {

std::vector<double> cutting_energy_mJ(const RecordingSeries& r, bool predicted) {
  std::vector<double> e;
  if (!r.has_spindle()) return e;
  const auto& tau = predicted ? r.spindle_predicted_Nmm : r.spindle_measured_Nmm;
  e.resize(r.t_s.size(), 0.0);
  // N·mm × rad/s = mW; × s = mJ.
  auto power = [&](std::size_t k) { return (tau[k] - r.spindle_offset_Nmm[k]) * r.spin_rad_s[k]; };
  for (std::size_t k = 1; k < e.size(); ++k)
    e[k] = e[k - 1] + 0.5 * (power(k - 1) + power(k)) * (r.t_s[k] - r.t_s[k - 1]);
  return e;
}

void add_wrench_plot_data(const RecordingSeries& r, std::size_t stride, json& rec) {
  const std::size_t n = r.t_s.size(), k = std::max<std::size_t>(1, stride);
  if (r.has_torque()) {
    json m = json::array({json::array(), json::array(), json::array()}), p = m;
    for (std::size_t i = 0; i < n; i += k)
      for (int a = 0; a < 3; ++a) {
        m[a].push_back(r.torque_measured_Nmm[i][a]);
        p[a].push_back(r.torque_predicted_Nmm[i][a]);
      }
    rec["tm"] = m;
    rec["tp"] = p;
  }
  if (r.has_spindle()) {
    const auto em = cutting_energy_mJ(r, false), ep = cutting_energy_mJ(r, true);
    json sm = json::array(), sp = json::array(), jem = json::array(), jep = json::array();
    for (std::size_t i = 0; i < n; i += k) {
      sm.push_back(r.spindle_measured_Nmm[i]);
      sp.push_back(r.spindle_predicted_Nmm[i]);
      jem.push_back(em[i]);
      jep.push_back(ep[i]);
    }
    rec["sm"] = sm;
    rec["sp"] = sp;
    rec["em"] = jem;
    rec["ep"] = jep;
  }
}

namespace {

// Per recording: each class's α·(removed volume) beside the replay's friction work on it
// (equal by the energy balance), and the spindle's cutting energy measured and predicted.
std::string energy_table(const ReportData& in) {
  std::string h =
      "<h3>Cutting energy</h3><p class=\"muted\">Per recording and bone class: α·(removed volume), the "
      "work erosion takes, beside the replay's friction work ∫ΣW dt on that class (equal by the energy "
      "balance, MODEL.md). The spindle's cutting energy is ∫(τ − idle − viscous)·|ω| dt over the "
      "recording, from the measured load and from the predicted one (the fitted idle and viscous terms, "
      "or the tare, removed from both): the drive's own measure of α·(removed volume). 1 N·mm = 1 mJ.</p>"
      "<div class=\"scroll\"><table id=\"energy-table\"><tr><th>recording</th><th>class</th><th>α (N/mm²)</th>"
      "<th>removed (mm³)</th><th>α·removed (mJ)</th><th>∫ΣW dt (mJ)</th><th>spindle energy predicted (mJ)</th>"
      "<th>spindle energy measured (mJ)</th><th>measured / predicted</th></tr>";
  bool any = false;
  for (const auto& r : in.recordings) {
    if (r.role == "validate" && r.id.size() > 9 && r.id.ends_with("@validate")) continue;  // same replay
    if (r.energy.empty() && !r.has_spindle()) continue;
    any = true;
    double sum_alpha = 0, sum_w = 0;
    for (const auto& e : r.energy) {
      sum_alpha += e.alpha_N_per_mm2 * e.removed_mm3;
      sum_w += e.friction_energy_mJ;
      h += "<tr>" + td(esc(r.id)) + td(esc(e.class_name)) + td(num(e.alpha_N_per_mm2), true) +
           td(num(e.removed_mm3), true) + td(num(e.alpha_N_per_mm2 * e.removed_mm3), true) +
           td(num(e.friction_energy_mJ), true) + td("") + td("") + td("") + "</tr>";
    }
    std::string pred = "—", meas = "—", ratio = "—";
    if (r.has_spindle()) {
      const double ep = cutting_energy_mJ(r, true).back(), em = cutting_energy_mJ(r, false).back();
      pred = num(ep);
      if (r.spindle_offset_source == "none") {
        meas = "no idle reference";  // fewer than 10 samples without contact, no fitted idle
      } else {
        meas = num(em);
        ratio = ep > 0 ? num(em / ep, 3) : "n/a";
      }
    }
    h += "<tr><th>" + esc(r.id) + "</th><th>all classes</th>" + td("") + td("") +
         td("<b>" + num(sum_alpha) + "</b>", true) + td("<b>" + num(sum_w) + "</b>", true) +
         td("<b>" + pred + "</b>", true) + td("<b>" + meas + "</b>", true) + td("<b>" + ratio + "</b>", true) + "</tr>";
  }
  h += "</table></div>";
  return any ? h : std::string();
}

// fit.json channel_information: the 95 % factors and the C1–α correlation, from the
// force alone and from every channel.
std::string identifiability_table(const json& ci) {
  if (!ci.is_object() || !ci.contains("parameters") || !ci.at("parameters").is_array()) return {};
  auto factor = [](const json& p, const char* k) {
    return p.contains(k) && p.at(k).is_number() ? "×/÷ " + num(p.at(k).get<double>()) : std::string("not identifiable");
  };
  std::string chans;
  if (ci.contains("channels") && ci.at("channels").is_array())
    for (const auto& c : ci.at("channels"))
      if (c.is_string()) chans += (chans.empty() ? "" : ", ") + c.get<std::string>();
  std::string h =
      "<h3>Identifiability with and without the new channels</h3><p class=\"muted\">Channels fitted: " +
      esc(chans) +
      ". Linearised 95 % interval of each constant (×/÷ the factor around its estimate) from the force "
      "rows alone and from every channel, at the same optimum and on the same scale (residual variance and "
      "noise model); the profile intervals above are the fit's own. " +
      esc(ci.value("method", std::string())) +
      ".</p><div class=\"scroll\"><table id=\"channel-table\"><tr><th>class</th><th>parameter</th>"
      "<th>force alone</th><th>all channels</th><th>narrower by</th></tr>";
  for (const auto& p : ci.at("parameters")) {
    const bool both = p.contains("se_log_force") && p.at("se_log_force").is_number() &&
                      p.contains("se_log_all") && p.at("se_log_all").is_number() && p.at("se_log_all").get<double>() > 0;
    h += "<tr>" + td(esc(p.value("class_name", std::string()))) + td(esc(p.value("name", std::string()))) +
         td(factor(p, "ci95_factor_force"), true) + td(factor(p, "ci95_factor_all"), true) +
         td(both ? "×" + num(p.at("se_log_force").get<double>() / p.at("se_log_all").get<double>(), 3) + " (in ln θ)"
                 : std::string("—"), true) + "</tr>";
  }
  if (ci.contains("correlations") && ci.at("correlations").is_array())
    for (const auto& c : ci.at("correlations")) {
      auto v = [&](const char* k) { return c.contains(k) && c.at(k).is_number() ? num(c.at(k).get<double>(), 4) : std::string("n/a"); };
      h += "<tr>" + td(esc(c.value("class_name", std::string()))) + td("correlation C1–α") + td(v("force"), true) +
           td(v("all"), true) + td("") + "</tr>";
    }
  return h + "</table></div>";
}

}  // namespace

std::string wrench_section(const ReportData& in, const json* fit) {
  std::string h;
  bool any = false;
  for (std::size_t i = 0; i < in.recordings.size(); ++i) {
    const auto& r = in.recordings[i];
    if (!r.has_torque() && !r.has_spindle()) continue;
    if (!any)
      h += "<p class=\"muted\">The sensor's moment (sensor frame, about its origin) and the spindle drive's "
           "load torque, measured against predicted from the burr's wrench (MODEL.md). Predicted series "
           "carry the fitted moment bias and the drive's idle and viscous terms (or the tare without a "
           "fit).</p>";
    any = true;
    h += "<h3>" + esc(r.id) + "</h3>";
    if (r.has_torque()) h += fmt::format("<div class=\"plot\" id=\"plot-torque-{}\"></div>", i);
    if (r.has_spindle())
      h += fmt::format("<div class=\"plotrow\"><div class=\"plot\" id=\"plot-spindle-{}\"></div>"
                       "<div class=\"plot\" id=\"plot-energy-{}\"></div></div>", i, i);
  }
  if (!any)
    h += "<p class=\"muted\">No recording logged the sensor's moments or the spindle's load.</p>";
  h += energy_table(in);
  if (fit && fit->contains("channel_information")) h += identifiability_table(fit->at("channel_information"));
  return h;
}

}  // namespace burrbench::analysis
