#include "burrbench/rig/finalise.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <utility>

#include <fmt/format.h>
#include <glm/vec2.hpp>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/rig/decode.hpp"
#include "burrbench/rig/register_map.hpp"

namespace burrbench::rig {

nlohmann::json to_json(const SessionHeader& h) {
  return {{"format", "burrbench.journal.header"}, {"rig_file", h.rig_file}, {"rig_sha256", h.rig_sha256},
          {"rig_toml", h.rig_toml}, {"sample_id", h.sample_id}, {"notes", h.notes},
          {"tare_file", h.tare_file}, {"tare_sha256", h.tare_sha256}, {"bias", h.bias},
          {"bias_t_ns", h.bias_t_ns}, {"session_wall_ns", h.session_wall_ns},
          {"session_monotonic_ns", h.session_monotonic_ns}, {"command_line", h.command_line},
          {"software_version", h.software_version}, {"created_utc", h.created_utc},
          {"operator", h.operator_name}, {"burr_radius_mm", h.burr_radius_mm}, {"burr_axis_rig", h.burr_axis_rig},
          {"spin_sign", h.spin_sign}};
}

SessionHeader header_from_json(const std::string& text, const std::string& file) {
  SessionHeader h;
  try {
    const auto j = nlohmann::json::parse(text);
    if (j.at("format") != "burrbench.journal.header") throw InputError(file, "header.format", "burrbench.journal.header");
    h.rig_file = j.at("rig_file");
    h.rig_sha256 = j.at("rig_sha256");
    h.rig_toml = j.at("rig_toml");
    h.sample_id = j.at("sample_id");
    h.notes = j.at("notes");
    h.tare_file = j.at("tare_file");
    h.tare_sha256 = j.at("tare_sha256");
    h.bias = j.at("bias").get<std::vector<double>>();
    h.bias_t_ns = j.at("bias_t_ns");
    h.session_wall_ns = j.at("session_wall_ns");
    h.session_monotonic_ns = j.at("session_monotonic_ns");
    h.command_line = j.at("command_line");
    h.software_version = j.at("software_version");
    h.created_utc = j.at("created_utc");
    // Since the twenty-first session; a journal written before has none of them.
    h.operator_name = j.value("operator", std::string());
    h.burr_radius_mm = j.value("burr_radius_mm", 0.0);
    h.burr_axis_rig = j.value("burr_axis_rig", std::vector<double>{});
    h.spin_sign = j.value("spin_sign", 0);
    if (!h.burr_axis_rig.empty() && h.burr_axis_rig.size() != 3)
      throw InputError(file, "header.burr_axis_rig", "3 numbers or none", std::to_string(h.burr_axis_rig.size()) + " numbers");
  } catch (const nlohmann::json::exception& e) {
    throw InputError(file, "header", "the JSON session header of a burrbench journal", e.what());
  }
  return h;
}

namespace {

// What the polls prove about their newest records, as points (counter, host ns): each
// was taken before its reply came (t ≤ recv: `upper`) and, while the device keeps
// sampling, at most one period before its request reached the device (t > send − period:
// `lower`, at send). Only the vertices of the upper points' lower convex hull (and of the
// lower points' upper hull) can bound a line, so only they are kept: the fit below then
// costs the same for an hour's polls as for a second's.
struct ClockBounds {
  std::vector<glm::dvec2> upper, lower;
};

// Adds p (x increasing) to a monotone-chain hull: the lower one when `below`, else the upper.
void add_to_hull(std::vector<glm::dvec2>& h, glm::dvec2 p, bool below) {
  while (h.size() >= 2) {
    const glm::dvec2 a = h[h.size() - 2], b = h.back();
    const double turn = (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);  // > 0: left turn
    if (below ? turn > 0 : turn < 0) break;
    h.pop_back();
  }
  h.push_back(p);
}

// The intercepts [lo, hi] (relative to t0, counter c0) that slope b leaves to the line
// t = t0 + a + b·(c − c0) between all the polls' bounds; empty when lo > hi.
std::pair<double, double> intercept_bounds(const ClockBounds& bounds, double b, double c0, double t0) {
  double lo = -1e300, hi = 1e300;
  for (const auto& p : bounds.upper) hi = std::min(hi, (p.y - t0) - b * (p.x - c0));
  for (const auto& p : bounds.lower) lo = std::max(lo, (p.y - t0) - b - b * (p.x - c0));
  return {lo, hi};
}

// The room hi − lo that slope b leaves the intercept; negative where no line of that slope
// fits between all the bounds. It is concave in b (a minimum of lines minus a maximum of
// lines), so golden sections and bisections over b are exact searches.
double room(const ClockBounds& bounds, double b, double c0, double t0) {
  const auto [lo, hi] = intercept_bounds(bounds, b, c0, t0);
  return hi - lo;
}

// The slope in [b_min, b_max] that leaves the widest room: the least-violating one when no
// line fits.
double widest_slope(const ClockBounds& bounds, double b_min, double b_max, double c0, double t0) {
  const double r = 0.5 * (std::sqrt(5.0) - 1.0);
  double x1 = b_max - r * (b_max - b_min), x2 = b_min + r * (b_max - b_min);
  double f1 = room(bounds, x1, c0, t0), f2 = room(bounds, x2, c0, t0);
  for (int it = 0; it < 100 && b_max - b_min > 1e-12 * b_max; ++it) {  // 0.618^100: far below 1 ps
    if (f1 < f2) {
      b_min = x1; x1 = x2; f1 = f2;
      x2 = b_min + r * (b_max - b_min); f2 = room(bounds, x2, c0, t0);
    } else {
      b_max = x2; x2 = x1; f2 = f1;
      x1 = b_max - r * (b_max - b_min); f1 = room(bounds, x1, c0, t0);
    }
  }
  return 0.5 * (b_min + b_max);
}

// The edge of the slopes that fit, between `in` (room ≥ 0) and `out` (room < 0).
double edge_slope(const ClockBounds& bounds, double in, double out, double c0, double t0) {
  for (int it = 0; it < 100 && std::abs(out - in) > 1e-12 * std::abs(in); ++it) {
    const double mid = 0.5 * (in + out);
    (room(bounds, mid, c0, t0) >= 0 ? in : out) = mid;
  }
  return in;
}

struct ClockLine {
  double a, b;  // t = t0 + a + b·(c − c0), ns (a: NaN when no line fits)
  bool fits;    // some line passes between all the bounds
};

// The lines t = t0 + a + b·(c − c0) that pass between all the polls' bounds form a convex
// polygon in (a, b); the device's line is one of them and the data favour none over
// another. Its centroid is their mean, so each record's time is the mean of the times
// those lines give it. A busy host only ever delays requests and replies: delays widen the
// polygon but never move its edges off the device's line, where a least-squares slope
// through the polls' midpoints drifts with them (1 ms at the ends of 1.5 s under a busy
// neighbour). When no line fits, the least-violating slope is used, pinned to the replies.
ClockLine fit_clock_line(const ClockBounds& bounds, double b_min, double b_max, double c0, double t0) {
  const double best = widest_slope(bounds, b_min, b_max, c0, t0);
  if (room(bounds, best, c0, t0) < 0) return {NAN, best, false};  // the caller pins it to the replies
  const double b_lo = room(bounds, b_min, c0, t0) >= 0 ? b_min : edge_slope(bounds, best, b_min, c0, t0);
  const double b_hi = room(bounds, b_max, c0, t0) >= 0 ? b_max : edge_slope(bounds, best, b_max, c0, t0);
  // Area and first moments by the trapezoid rule over slices of constant b: the room and
  // the slice's middle are piecewise linear in b, so 1024 slices are plenty.
  constexpr int kSlices = 1024;
  double area = 0, sum_a = 0, sum_b = 0;
  for (int k = 0; k <= kSlices; ++k) {
    const double b = b_lo + (b_hi - b_lo) * k / kSlices;
    const auto [lo, hi] = intercept_bounds(bounds, b, c0, t0);
    const double w = std::max(0.0, hi - lo) * (k == 0 || k == kSlices ? 0.5 : 1.0);
    area += w;
    sum_a += w * 0.5 * (lo + hi);
    sum_b += w * b;
  }
  if (!(area > 0)) {  // a single line fits (a polygon of no area): take it
    const auto [lo, hi] = intercept_bounds(bounds, best, c0, t0);
    return {0.5 * (lo + hi), best, true};
  }
  return {sum_a / area, sum_b / area, true};
}

// FIFO device time: t = a + b·counter, per segment (a counter reset starts a new one), the
// centroid of the lines that pass between every poll's bounds on its newest record
// (fit_clock_line). The period b is kept only within 1 % of the nominal one; else the
// nominal period, with the middle of the bounds it leaves. Returns what a reader of the
// timestamps must know: where the fit fell back (a wrong device_rate_hz shows here).
std::vector<std::string> fit_fifo_time(data_schema::Stream& s, double device_rate_hz) {
  std::vector<std::string> notes;
  const std::size_t n = s.samples();
  const double nominal = 1e9 / device_rate_hz;
  std::size_t seg_start = 0;
  for (std::size_t i = 1; i <= n; ++i) {
    if (i < n && s.device_counter[i] > s.device_counter[i - 1]) continue;
    // The newest record of each poll (the last one with its t_send); counters increase.
    ClockBounds bounds;
    std::size_t polls = 0;
    double c0 = 0, t0 = 0, c_prev = 0, send_prev = 0;
    for (std::size_t k = seg_start; k < i; ++k) {
      if (k + 1 != i && s.t_send_ns[k + 1] == s.t_send_ns[k]) continue;
      const double c = static_cast<double>(s.device_counter[k]), send = static_cast<double>(s.t_send_ns[k]);
      if (polls++ == 0) c0 = c, t0 = send;
      add_to_hull(bounds.upper, {c, static_cast<double>(s.t_recv_ns[k])}, true);
      // A poll whose newest record advanced less than the time since the previous poll
      // explains (a device that paused or stopped, e.g. a played recording at its end)
      // proves no lower bound (2 records of slack for the trips).
      if (polls == 1 || (c - c_prev) + 2.0 >= (send - send_prev) / nominal) add_to_hull(bounds.lower, {c, send}, false);
      c_prev = c, send_prev = send;
    }
    double b = nominal;
    std::optional<ClockLine> line;
    if (polls >= 10 && c_prev > c0) {
      // Searched well beyond 1 % so that a wrong device_rate_hz is measured, not clipped.
      line = fit_clock_line(bounds, 0.5 * nominal, 2.0 * nominal, c0, t0);
      if (std::abs(line->b / nominal - 1.0) < 0.01) b = line->b;  // clock rate within 1 %: trust it
      else {
        notes.push_back(fmt::format("measured record period {:.6g} ms is not within 1 % of 1/device_rate_hz = "
                                    "{:.6g} ms (is device_rate_hz right?); the nominal period is used",
                                    line->b * 1e-6, nominal * 1e-6));
        line.reset();
      }
    }
    const auto [lo, hi] = intercept_bounds(bounds, b, c0, t0);
    // Within one period the bounds may touch the sampling itself (a record taken just as
    // a request arrived): pinned to the reply bound without a word. Beyond it, say so.
    if (lo > hi + b)
      notes.push_back(fmt::format("the polls' time bounds do not overlap ({:.3f} ms apart; is device_rate_hz "
                                  "right?): timestamps pinned to the latest reply bound", (lo - hi) * 1e-6));
    const double a = t0 + (line && line->fits ? line->a : lo <= hi ? 0.5 * (lo + hi) : hi);
    for (std::size_t k = seg_start; k < i; ++k)
      s.t_ns[k] = static_cast<std::int64_t>(std::llround(a + b * (static_cast<double>(s.device_counter[k]) - c0)));
    seg_start = i;
  }
  return notes;
}

// A span of polls whose counter repeated the value of the fresh sample at `first_ns`.
struct FrozenSpan {
  std::int64_t first_ns = 0, last_ns = 0;
  std::size_t polls = 0;
  double span_s() const { return 1e-9 * double(last_ns - first_ns); }
};

}  // namespace

data_schema::Recording recording_from_journal(const JournalContents& j, const std::string& file,
                                              FinaliseReport* report) {
  const auto h = header_from_json(j.header_json, file);
  const auto map = parse_rig_map(h.rig_toml, h.rig_file.empty() ? file : h.rig_file);
  data_schema::Recording rec;
  auto& m = rec.meta;
  m.sample_id = h.sample_id;
  m.operator_name = h.operator_name;
  m.burr_radius_mm = h.burr_radius_mm;
  if (h.burr_axis_rig.size() == 3) m.burr_axis_rig = {h.burr_axis_rig[0], h.burr_axis_rig[1], h.burr_axis_rig[2]};
  m.spin_sign = h.spin_sign;
  m.rig_id = map.rig_id;
  m.sensor_model = map.sensor_model;
  m.sensor_serial = map.sensor_serial;
  m.sensor_calibration_date = map.sensor_calibration_date;
  m.bias = h.bias;
  m.bias_t_ns = h.bias_t_ns;
  m.register_map_toml = h.rig_toml;
  m.session_wall_ns = h.session_wall_ns;
  m.session_monotonic_ns = h.session_monotonic_ns;
  m.notes = h.notes;
  FinaliseReport rep;
  rep.problems = j.problems;

  std::vector<std::vector<const JournalSample*>> per(map.devices.size());
  for (const auto& s : j.samples) {
    if (s.device >= map.devices.size() ||
        s.regs.size() != static_cast<std::size_t>(map.devices[s.device].sample_registers())) {
      rep.problems.push_back(fmt::format("sample record for device {} with {} registers does not match the map, skipped",
                                         s.device, s.regs.size()));
      continue;
    }
    per[s.device].push_back(&s);
  }
  for (std::size_t di = 0; di < map.devices.size(); ++di) {
    const auto& d = map.devices[di];
    auto& samples = per[di];
    // Journal order is acquisition order; a skipped block cannot reorder the rest.
    std::stable_sort(samples.begin(), samples.end(), [&](auto* a, auto* b) {
      return d.mode == Mode::Fifo ? (a->t_send_ns < b->t_send_ns || (a->t_send_ns == b->t_send_ns && a->counter < b->counter))
                                  : a->t_send_ns < b->t_send_ns;
    });
    data_schema::Stream st;
    st.name = d.name;
    st.registers_per_sample = static_cast<std::size_t>(d.sample_registers());
    const bool has_counter = d.counter || d.fifo;
    const int base = d.mode == Mode::Fifo ? 0 : d.start;
    std::vector<data_schema::Channel> chans;
    for (const auto& c : d.channels) chans.push_back({c.name, c.unit, c.registers.size(), {}});
    // bit 0: a value was invalid (NaN/Inf/out of range); bit 1: counter unchanged (repeat);
    // bit 2: the device's status word marked the sample invalid (its values are NaN)
    data_schema::Channel flags{"sample_flags", "1", 1, {}};
    std::vector<double> buf;
    // The longest span over which the device's counter did not advance: the device gave
    // no new measurement (stalled, or stopped measuring) while it kept answering.
    FrozenSpan frozen, run;
    for (const auto* s : samples) {
      st.t_send_ns.push_back(s->t_send_ns);
      st.t_recv_ns.push_back(s->t_recv_ns);
      st.t_ns.push_back(s->t_send_ns + (s->t_recv_ns - s->t_send_ns) / 2);
      st.raw_registers.insert(st.raw_registers.end(), s->regs.begin(), s->regs.end());
      if (has_counter) st.device_counter.push_back(s->counter);
      const bool stale = d.mode == Mode::Latest && has_counter && st.device_counter.size() >= 2 &&
                         s->counter == st.device_counter[st.device_counter.size() - 2];
      bool values_ok = true;
      const bool status_bad = status_invalid(d, s->regs, base);
      for (std::size_t c = 0; c < d.channels.size(); ++c) {
        buf.assign(d.channels[c].registers.size(), 0.0);
        const bool decoded = decode_channel(d.channels[c], s->regs, base, buf);
        values_ok = values_ok && decoded;
        if (status_bad) buf.assign(buf.size(), std::numeric_limits<double>::quiet_NaN());
        if (!decoded || status_bad) {
          // NaN on a stale row is the recording's "no fresh value" marker; positions
          // must stay finite, so they hold 0 and rely on the stale flag alone.
          if (d.channels[c].name == data_schema::kPosition)
            for (auto& v : buf)
              if (std::isnan(v)) v = 0.0;
        }
        chans[c].values.insert(chans[c].values.end(), buf.begin(), buf.end());
      }
      const bool ok = values_ok && !status_bad;
      st.stale.push_back((stale || !ok) ? 1 : 0);
      flags.values.push_back((values_ok ? 0.0 : 1.0) + (stale ? 2.0 : 0.0) + (status_bad ? 4.0 : 0.0));
      rep.stale += stale;
      rep.invalid += !ok;
      if (!stale) {
        run = {st.t_ns.back(), st.t_ns.back(), 0};
      } else {
        run.last_ns = st.t_ns.back();
        ++run.polls;
        if (run.span_s() > frozen.span_s()) frozen = run;
      }
    }
    if (frozen.span_s() >= kFrozenAfterS) {
      const auto rel = [&](std::int64_t t) { return 1e-9 * double(t - h.session_monotonic_ns); };
      const std::string note = fmt::format(
          "its counter did not advance for {:.2f} s ({} polls, {:.2f} s to {:.2f} s into the session): the device "
          "gave no new measurement over that span (stalled, or stopped measuring); those rows are marked stale",
          frozen.span_s(), frozen.polls, rel(frozen.first_ns), rel(frozen.last_ns));
      rec.events.push_back({frozen.first_ns, "frozen", d.name, note});
      rep.problems.push_back(d.name + ": " + note);
    }
    if (d.calibration) {
      const auto& cal = *d.calibration;
      const auto it = std::find_if(chans.begin(), chans.end(), [&](auto& c) { return c.name == cal.input; });
      data_schema::Channel f{data_schema::kForce, "N", 3, {}}, t{data_schema::kTorque, "N*mm", 3, {}};
      for (std::size_t k = 0; k < st.samples(); ++k) {
        const double* raw = it->values.data() + 6 * k;
        for (int r = 0; r < 6; ++r) {
          double v = 0;
          for (int c = 0; c < 6; ++c) v += cal.matrix[static_cast<std::size_t>(r * 6 + c)] * raw[c];
          (r < 3 ? f : t).values.push_back(v);
        }
      }
      chans.push_back(std::move(f));
      chans.push_back(std::move(t));
      m.sensor_calibration.assign(cal.matrix.begin(), cal.matrix.end());
    }
    chans.push_back(std::move(flags));
    st.channels = std::move(chans);
    if (d.mode == Mode::Fifo && st.samples() > 0)
      for (auto& note : fit_fifo_time(st, d.fifo->device_rate_hz)) {
        rec.events.push_back({st.t_ns.front(), "clock_fit", d.name, note});
        rep.problems.push_back(d.name + ": " + note);
      }
    rep.samples += st.samples();
    rec.streams.push_back(std::move(st));
  }
  for (const auto& e : j.events) {
    const std::string stream = (e.device >= 0 && static_cast<std::size_t>(e.device) < map.devices.size())
                                   ? map.devices[static_cast<std::size_t>(e.device)].name : "";
    rec.events.push_back({e.t_ns, e.kind, stream, e.detail});
  }
  const std::int64_t t_end = j.events.empty() ? h.session_monotonic_ns : j.events.back().t_ns;
  if (!j.clean_end) rec.events.push_back({t_end, "recovered", "", "journal had no end marker (crash or kill)"});
  for (const auto& p : j.problems) rec.events.push_back({t_end, "journal_damage", "", p});
  std::stable_sort(rec.events.begin(), rec.events.end(), [](auto& a, auto& b) { return a.t_ns < b.t_ns; });
  if (report) *report = rep;
  return rec;
}

}  // namespace burrbench::rig
