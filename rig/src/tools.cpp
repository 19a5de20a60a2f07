#include "burrbench/rig/tools.hpp"

#include <time.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "burrbench/data_schema/atomic_file.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/format_version.hpp"
#include "burrbench/data_schema/toml_input.hpp"
#include "burrbench/data_schema/toml_view.hpp"
#include "burrbench/rig/decode.hpp"
#include "burrbench/rig/modbus_link.hpp"

namespace burrbench::rig {
namespace {

// Decoded channels of one sample, with the calibration applied when the map has one.
std::vector<CheckedChannel> decode_sample(const DeviceSpec& d, const std::vector<std::uint16_t>& block) {
  std::vector<std::uint16_t> regs = block;
  int base = d.start;
  if (d.mode == Mode::Fifo) {
    const auto& f = *d.fifo;
    const auto* rec = block.data() + (f.first_register - d.start) + (f.depth - 1) * f.record_registers;
    regs.assign(rec, rec + f.record_registers);
    base = 0;
  }
  std::vector<CheckedChannel> out;
  for (const auto& c : d.channels) {
    CheckedChannel cc{c.name, c.unit, std::vector<double>(c.registers.size()), true};
    cc.valid = decode_channel(c, regs, base, cc.values);
    out.push_back(std::move(cc));
  }
  if (d.calibration) {
    for (const auto& c : out) {
      if (c.name != d.calibration->input) continue;
      CheckedChannel f{"force_N", "N", std::vector<double>(3), c.valid}, t{"torque_Nmm", "N*mm", std::vector<double>(3), c.valid};
      for (int r = 0; r < 6; ++r) {
        double v = 0;
        for (int k = 0; k < 6; ++k) v += d.calibration->matrix[static_cast<std::size_t>(r * 6 + k)] * c.values[static_cast<std::size_t>(k)];
        (r < 3 ? f : t).values[static_cast<std::size_t>(r % 3)] = v;
      }
      out.push_back(f);
      out.push_back(t);
      break;
    }
  }
  return out;
}

std::int64_t wall_ns() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

}  // namespace

std::vector<CheckResult> check_rig(const RigMap& map) {
  std::vector<CheckResult> out;
  for (const auto& d : map.devices) {
    CheckResult r;
    r.device = d.name;
    ModbusLink link(d);
    r.link = link.describe();
    std::string err;
    if (!link.connect(&err)) {
      r.error = err;
      out.push_back(r);
      continue;
    }
    std::vector<std::uint16_t> regs;
    const auto rr = link.read(d, regs);
    r.round_trip_ms = static_cast<double>(rr.t_recv_ns - rr.t_send_ns) * 1e-6;
    if (rr.status != ReadStatus::Ok) {
      r.error = fmt::format("{}: {}", to_string(rr.status), rr.detail);
    } else {
      r.ok = true;
      if (d.counter) r.counter = decode_integer(regs.data() + (d.counter->address - d.start), d.counter->type, d.counter->order);
      if (d.fifo) r.counter = decode_integer(regs.data() + (d.fifo->counter.address - d.start), d.fifo->counter.type, d.fifo->counter.order);
      r.channels = decode_sample(d, regs);
    }
    out.push_back(std::move(r));
  }
  return out;
}

void TareSums::add(const std::array<double, 6>& w) {
  const bool second_half = 2 * n_ >= planned_;
  for (std::size_t k = 0; k < 6; ++k) {
    sum_[k] += w[k];
    sq_[k] += w[k] * w[k];
    if (second_half) second_[k] += w[k];
  }
  ++n_;
}

void TareSums::finish(Tare& t) const {
  t.samples = n_;
  t.bias.clear();
  t.stddev.clear();
  t.drift.clear();
  t.drift_sigmas = 0;
  if (n_ == 0) return;
  const double n = static_cast<double>(n_);
  const std::size_t first_half = std::min(n_, (planned_ + 1) / 2);
  const double n1 = static_cast<double>(first_half), n2 = n - n1;
  for (std::size_t k = 0; k < 6; ++k) {
    const double mean = sum_[k] / n;
    t.bias.push_back(mean);
    t.stddev.push_back(std::sqrt(std::max(0.0, sq_[k] / n - mean * mean)));
    const double m1 = (sum_[k] - second_[k]) / n1, m2 = n2 > 0 ? second_[k] / n2 : m1;
    t.drift.push_back(m2 - m1);
    // The noise about each half's own mean (pooled), so that the drift does not hide in a
    // stddev it inflates; the standard error of the difference of the two half means.
    if (k < 3 && n2 > 0 && n > 2) {
      const double within = std::max(0.0, (sq_[k] - n1 * m1 * m1 - n2 * m2 * m2) / (n - 2));
      const double se = std::sqrt(within * (1.0 / n1 + 1.0 / n2));
      if (se > 0) t.drift_sigmas = std::max(t.drift_sigmas, std::abs(m2 - m1) / se);
    }
  }
}

Tare measure_tare(const RigMap& map, std::size_t samples) {
  const DeviceSpec* dev = nullptr;
  for (const auto& d : map.devices) {
    bool f = d.calibration.has_value(), t = d.calibration.has_value();
    for (const auto& c : d.channels) {
      f = f || (c.name == "force_N" && c.registers.size() == 3);
      t = t || (c.name == "torque_Nmm" && c.registers.size() == 3);
    }
    if (f && t) { dev = &d; break; }
  }
  if (!dev) throw InputError(map.file, "devices", "a device with 3-column force_N and torque_Nmm channels (or a calibration) to tare");
  ModbusLink link(*dev);
  std::string err;
  if (!link.connect(&err)) throw std::runtime_error(err);
  TareSums sums(samples);
  std::size_t got = 0, failures = 0;
  std::int64_t first = 0, last = 0;
  const auto period = std::chrono::duration<double>(1.0 / dev->rate_hz);
  std::vector<std::uint16_t> regs;
  while (got < samples) {
    const auto r = link.read(*dev, regs);
    if (r.status != ReadStatus::Ok) {
      if (++failures > 10 + samples / 10)
        throw std::runtime_error(fmt::format("{}: tare aborted after {} failed reads: {}", dev->name, failures, r.detail));
      link.recover_after(*dev, r);
      if (!link.connected() && !link.connect(&err)) throw std::runtime_error(err);
      continue;
    }
    std::vector<double> w;
    bool valid = true;
    for (const auto& c : decode_sample(*dev, regs))
      if (c.name == "force_N" || c.name == "torque_Nmm") {
        w.insert(c.name == "force_N" ? w.begin() : w.end(), c.values.begin(), c.values.end());
        valid = valid && c.valid;
      }
    if (!valid) {
      ++failures;
      continue;
    }
    sums.add({w[0], w[1], w[2], w[3], w[4], w[5]});
    const auto mid = r.t_send_ns + (r.t_recv_ns - r.t_send_ns) / 2;
    if (got++ == 0) first = mid;
    last = mid;
    std::this_thread::sleep_for(period);
  }
  Tare t;
  t.device = dev->name;
  sums.finish(t);
  t.t_ns = first + (last - first) / 2;
  t.wall_ns = wall_ns() - (monotonic_ns() - t.t_ns);
  return t;
}

void write_tare(const std::filesystem::path& path, const Tare& t) {
  toml::table root{{"format", "burrbench.tare"}, {"format_version", "1.0"}, {"device", t.device},
                   {"samples", static_cast<std::int64_t>(t.samples)}, {"t_monotonic_ns", t.t_ns},
                   {"t_wall_ns", t.wall_ns}, {"rig_sha256", t.rig_sha256}};
  toml::array bias, sd;
  for (double v : t.bias) bias.push_back(v);
  for (double v : t.stddev) sd.push_back(v);
  root.insert("bias", bias);
  root.insert("stddev", sd);
  std::ostringstream text;
  text << "# Sensor bias (Fx,Fy,Fz N, Tx,Ty,Tz N*mm) written by burrbench rig tare\n" << root << "\n";
  data_schema::write_file_atomic(path, text.str());
}

Tare read_tare(const std::filesystem::path& path) {
  const ReadingFile reading(path.string());  // names it if memory runs out
  const std::string file = path.string();
  const toml::table root = data_schema::parse_toml_file(path);
  const data_schema::TomlView v(root, file, "", "docs/rig.md");
  data_schema::check_format(file, "format", v.str("format"), "burrbench.tare");
  data_schema::check_version(file, "format_version", v.str_or("format_version", "1.0"), 1);
  Tare t;
  t.device = v.str_or("device", "");
  t.bias = v.numbers("bias", 6);
  if (v.has("stddev")) t.stddev = v.numbers("stddev", 6);
  t.t_ns = v.integer("t_monotonic_ns");
  t.wall_ns = v.has("t_wall_ns") ? v.integer("t_wall_ns") : 0;
  t.samples = static_cast<std::size_t>(v.integer_or("samples", 0, std::numeric_limits<std::int64_t>::max(), 0));
  t.rig_sha256 = v.str_or("rig_sha256", "");
  v.done();
  return t;
}

}  // namespace burrbench::rig
