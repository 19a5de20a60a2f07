#include "burrbench/calibration/parameters.hpp"

#include <algorithm>
#include <cmath>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::calibration {

const char* to_string(PhysKind k) {
  switch (k) {
    case PhysKind::kAlpha: return "alpha";
    case PhysKind::kC1: return "c1";
    case PhysKind::kMu: return "mu";
  }
  BURRBENCH_UNREACHABLE();
}

const char* unit_of(PhysKind k) { return k == PhysKind::kMu ? "1" : "N/mm^2"; }
Layout::Layout(
    const std::vector<std::pair<std::uint8_t, std::pair<std::string, data_schema::ClassFitSpec>>>&
        classes,
    const std::vector<std::pair<std::string, double>>& recordings_lag_ms,
    const data_schema::NuisanceSpec& nuisance, double depth_bound_mm, Channels channels)
    : channels_(channels) {
  auto add = [&](std::string name, double init, double lo, double hi, bool log, std::size_t size) {
    blocks_.push_back({n_, size});
    for (std::size_t k = 0; k < size; ++k) {
      names_.push_back(size == 1 ? name : name + "_" + "xyz"[k]);
      init_.push_back(log ? std::log(init) : init);
      lower_.push_back(log ? std::log(lo) : lo);
      upper_.push_back(log ? std::log(hi) : hi);
      log_.push_back(log);
    }
    n_ += size;
    return int(n_ - size);
  };
  for (const auto& [label, named] : classes) {
    BURRBENCH_CHECK(label > 0 && label < kLabels, "class label out of range");
    const auto& [cname, spec] = named;
    for (PhysKind kind : {PhysKind::kAlpha, PhysKind::kC1, PhysKind::kMu}) {
      PhysicsParam p{label, cname, kind,
                     kind == PhysKind::kAlpha ? spec.alpha
                     : kind == PhysKind::kC1  ? spec.c1
                                              : spec.mu,
                     -1};
      if (!p.spec.fixed) {
        BURRBENCH_CHECK(p.spec.lower > 0 && p.spec.lower < p.spec.upper,
                        "free physics parameter needs 0 < lower < upper");
        p.index = add(cname + "." + to_string(kind), p.spec.initial, p.spec.lower,
                      p.spec.upper, true, 1);
      }
      physics_.push_back(std::move(p));
    }
  }
  for (const auto& [id, lag_ms] : recordings_lag_ms) {
    RecordingNuisance r;
    r.recording_id = id;
    r.lag_fixed_ms = lag_ms;
    r.lag_bounds_ms = nuisance.lag_bounds_ms;
    r.depth_bound_mm = depth_bound_mm;
    if (nuisance.bias) r.bias = add(id + ".bias", 0.0, -1e6, 1e6, false, 3);
    if (nuisance.lag) {
      // The start value must lie strictly inside the bounds for the solver.
      const double lo = r.lag_bounds_ms[0], hi = r.lag_bounds_ms[1];
      const double start = std::clamp(lag_ms, lo + 1e-9 * (hi - lo), hi - 1e-9 * (hi - lo));
      r.lag = add(id + ".lag", start, lo, hi, false, 1);
    }
    if (nuisance.depth_offset)
      r.depth = add(id + ".depth_offset", 0.0, -depth_bound_mm, depth_bound_mm, false, 1);
    if (channels.torque) r.torque_bias = add(id + ".torque_bias", 0.0, -1e9, 1e9, false, 3);
    if (channels.spindle) {  // one block: offset and viscous term
      r.spindle = add(id + ".spindle", 0.0, -1e9, 1e9, false, 2);
      names_[std::size_t(r.spindle)] = id + ".spindle_idle";
      names_[std::size_t(r.spindle) + 1] = id + ".spindle_viscous";
      // The drive is another device, polled and timestamped on its own: its lag against the
      // force is its own (docs/calibration.md "Channels").
      if (nuisance.lag) r.spindle_lag = add(id + ".spindle_lag", 0.0, r.lag_bounds_ms[0], r.lag_bounds_ms[1], false, 1);
    }
    recordings_.push_back(std::move(r));
  }
  // Biases and idle terms have no real bound: drop the placeholder bounds (Ceres: unbounded).
  auto unbound = [&](int at, int size) {
    for (int k = 0; at >= 0 && k < size; ++k) {
      lower_[std::size_t(at + k)] = -std::numeric_limits<double>::infinity();
      upper_[std::size_t(at + k)] = std::numeric_limits<double>::infinity();
    }
  };
  for (auto& r : recordings_) {
    unbound(r.bias, 3);
    unbound(r.torque_bias, 3);
    unbound(r.spindle, 2);
  }
}

void Layout::add_mounting(Mounting m, const std::vector<std::size_t>& recs) {
  m.offset = int(n_);
  static const char* kNames[6] = {"pose_rx", "pose_ry", "pose_rz", "pose_tx", "pose_ty", "pose_tz"};
  blocks_.push_back({n_, 6});
  for (int k = 0; k < 6; ++k) {
    names_.push_back(m.name + "." + kNames[k]);
    init_.push_back(0.0);
    const double b = k < 3 ? 0.05 : 1.0;  // rad, mm: far beyond any fiducial fit worth using
    lower_.push_back(-b);
    upper_.push_back(b);
    log_.push_back(false);
  }
  n_ += 6;
  for (std::size_t r : recs) {
    recordings_.at(r).pose = m.offset;
    recordings_.at(r).mounting = int(mountings_.size());
  }
  mountings_.push_back(std::move(m));
}

const PhysicsParam* Layout::physics_at(std::size_t entry) const {
  for (const auto& p : physics_)
    if (p.index == int(entry)) return &p;
  return nullptr;
}

void Layout::add_depth_offset(std::size_t recording) {
  RecordingNuisance& r = recordings_.at(recording);
  BURRBENCH_CHECK(r.depth < 0, "depth offset already free");
  r.depth = int(n_);
  blocks_.push_back({n_, 1});
  names_.push_back(r.recording_id + ".depth_offset");
  init_.push_back(0.0);
  lower_.push_back(-r.depth_bound_mm);
  upper_.push_back(r.depth_bound_mm);
  log_.push_back(false);
  ++n_;
}

std::vector<std::uint8_t> Layout::labels() const {
  std::vector<std::uint8_t> out;
  for (const auto& p : physics_)
    if (out.empty() || out.back() != p.label) out.push_back(p.label);
  return out;
}

std::vector<double> Layout::initial() const { return init_; }

PhysicsValues Layout::physics_values(const double* x) const {
  PhysicsValues v;
  for (const auto& p : physics_)
    v.at(p.kind, p.label) = p.index >= 0 ? std::exp(x[p.index]) : p.spec.initial;
  return v;
}

double Layout::natural(std::size_t i, double x) const { return log_[i] ? std::exp(x) : x; }
double Layout::dnatural(std::size_t i, double x) const { return log_[i] ? std::exp(x) : 1.0; }

}  // namespace burrbench::calibration
