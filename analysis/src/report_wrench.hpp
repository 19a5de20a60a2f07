#pragma once
// The report's section on the sensor's moments and the spindle's load (MODEL.md
// "Moments, the sensor's wrench and the spindle's load"): traces measured against
// predicted, the spindle's cutting energy against α·(removed volume) per class, and what
// the channels add to the identifiability (fit.json channel_information).
#include <string>

#include <nlohmann/json.hpp>

#include "burrbench/analysis/report_data.hpp"

namespace burrbench::analysis {

// The section's HTML body (plots are divs report.js fills: plot-torque-i,
// plot-spindle-i, plot-energy-i for recording i).
std::string wrench_section(const ReportData& in, const nlohmann::json* fit);

// Adds a recording's moment and spindle series to its plot data (every `stride`-th
// sample, as the force): tm/tp (3 axes), sm/sp, and the cumulative cutting energy
// em/ep (mJ).
void add_wrench_plot_data(const RecordingSeries& r, std::size_t stride, nlohmann::json& rec);

// Cumulative cutting energy ∫(τ − offset)·|ω| dt (mJ, trapezoid over the samples) of the
// spindle's load, measured (`predicted` false) or predicted; empty without a spindle load.
std::vector<double> cutting_energy_mJ(const RecordingSeries& r, bool predicted);

}  // namespace burrbench::analysis
