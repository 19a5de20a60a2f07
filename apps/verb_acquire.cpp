// burrbench acquire: poll the rig into a crash-safe journal, then finalise it into an
// HDF5 recording on Ctrl-C, SIGTERM or --duration.
#include <signal.h>
#include <time.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <memory>
#include <thread>
#include <typeinfo>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/progress.hpp"
#include "burrbench/data_schema/provenance.hpp"
#include "burrbench/data_schema/version.hpp"
#include "burrbench/data_schema/recording.hpp"
#include "burrbench/rig/finalise.hpp"
#include "burrbench/rig/modbus_link.hpp"
#include "burrbench/rig/session.hpp"
#include "burrbench/rig/tools.hpp"
#include "burrbench/watch/background.hpp"
#include "burr_options.hpp"
#include "output_paths.hpp"
#include "verb_registry.hpp"

namespace {

std::atomic<int> g_signal{0};
void on_signal(int sig) { g_signal = sig; }

struct Options {
  std::string rig, out, journal, sample_id, notes, tare;
  burrbench::apps::BurrOptions burr;
  double duration_s = 0;
  bool keep_journal = false;
  bool overwrite = false;
  // --watch: the live view beside the acquisition (docs/watch.md).
  std::string watch, watch_recording, watch_params, watch_fit, watch_bind = "127.0.0.1";
};

std::string live_line(const burrbench::rig::SessionStatus& s) {
  std::uint64_t samples = 0, timeouts = 0, reconnects = 0, polls = 0, missed = 0;
  double jitter = 0, rate = 0, req = 0;
  std::string force, frozen;
  for (const auto& d : s.devices) {
    if (d.frozen_s >= burrbench::rig::kFrozenAfterS) frozen += fmt::format("  FROZEN {} {:.1f} s", d.name, d.frozen_s);
    samples += d.samples;
    timeouts += d.timeouts;
    reconnects += d.reconnects;
    polls += d.polls;
    missed += d.missed_polls;
    jitter = std::max(jitter, d.jitter_p99_us);
    rate += d.achieved_hz;
    req += d.rate_hz;
    if (d.first_channel == burrbench::data_schema::kForce && d.last.size() == 3 && force.empty())
      force = fmt::format(" F {:.2f} {:.2f} {:.2f} N", d.last[0], d.last[1], d.last[2]);
  }
  return fmt::format("{:.0f}/{:.0f} Hz  jitter p99 {:.0f} µs{}  samples {}  timeouts {}  reconnects {}  missed {}{}",
                     rate, req, jitter, force, samples, timeouts, reconnects, missed, frozen);
}

// Tells the operator at once, on a line of its own, when a device still answering stops
// measuring (its counter no longer advances), and when it measures again: drilling on
// a frozen force sensor records nothing new.
class FrozenWatch {
 public:
  explicit FrozenWatch(std::size_t devices) : frozen_(devices, false) {}
  void check(const burrbench::rig::SessionStatus& s, burrbench::Progress& progress) {
    for (std::size_t i = 0; i < s.devices.size() && i < frozen_.size(); ++i) {
      const auto& d = s.devices[i];
      const bool now = d.frozen_s >= burrbench::rig::kFrozenAfterS;
      if (now && !frozen_[i])
        progress.note(fmt::format("WARNING: {} gives no new measurement: its counter has not advanced for {:.1f} s "
                                  "(stalled, or stopped measuring); its rows are marked stale",
                                  d.name, d.frozen_s));
      if (!now && frozen_[i]) progress.note(fmt::format("{} measures again", d.name));
      frozen_[i] = now;
    }
  }

 private:
  std::vector<bool> frozen_;
};

// Refused before the session, not after it: neither output may replace the map or tare,
// and a recording is the one copy of a session: never replaced unless asked.
void refuse_outputs(const Options& o, const std::filesystem::path& journal) {
  using namespace burrbench;
  apps::refuse_output_over_inputs(o.out, "--out", {o.rig, o.tare});
  apps::refuse_output_over_inputs(journal.string(), "--journal", {o.rig, o.tare, o.out});
  apps::refuse_existing(o.out, "--out", o.overwrite);
  apps::check_output_location(journal.string(), "--journal");
  if (std::filesystem::exists(journal))
    throw InputError(journal.string(), "(journal)", "no journal left from an earlier session (run `burrbench recover` on it, or remove it)", "exists");
}

// The journal's header: the map, the burr, the tare, the clocks and the provenance.
burrbench::rig::SessionHeader session_header(const Options& o, const burrbench::rig::RigMap& map,
                                             const burrbench::data_schema::RecordingMeta& burr) {
  using namespace burrbench;
  rig::SessionHeader h;
  h.rig_file = o.rig;
  h.rig_sha256 = sha256_file(o.rig);
  h.rig_toml = map.source_toml;
  h.sample_id = o.sample_id;
  h.notes = o.notes;
  h.operator_name = burr.operator_name;
  h.burr_radius_mm = burr.burr_radius_mm;
  if (burr.axis_stated()) h.burr_axis_rig = {burr.burr_axis_rig.x, burr.burr_axis_rig.y, burr.burr_axis_rig.z};
  h.spin_sign = burr.spin_sign;
  if (!o.tare.empty()) {
    const auto t = rig::read_tare(o.tare);
    h.tare_file = o.tare;
    h.tare_sha256 = sha256_file(o.tare);
    h.bias = t.bias;
    h.bias_t_ns = t.t_ns;
  }
  timespec wall{}, mono{};
  clock_gettime(CLOCK_REALTIME, &wall);
  clock_gettime(CLOCK_MONOTONIC, &mono);
  h.session_wall_ns = wall.tv_sec * 1'000'000'000LL + wall.tv_nsec;
  h.session_monotonic_ns = mono.tv_sec * 1'000'000'000LL + mono.tv_nsec;
  h.command_line = invocation();
  h.software_version = software_version();
  h.created_utc = make_provenance({}).created_utc;
  return h;
}

void catch_stop_signals() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  // A file-size limit (ulimit -f) must surface as a failed journal write, which stops the
  // acquisition loudly and keeps the journal, not as a signal that kills the process.
  signal(SIGXFSZ, SIG_IGN);
}

// Polls until Ctrl-C, --duration or a fatal fault, with the live line; then stops the
// session. Returns its status after the last polls.
burrbench::rig::SessionStatus acquire(burrbench::rig::Session& session, const burrbench::rig::RigMap& map,
                                      const Options& o, const std::filesystem::path& journal) {
  using namespace burrbench;
  std::cerr << fmt::format("acquiring {} device(s) into journal {} (Ctrl-C stops)\n", map.devices.size(), journal.string());
  TerminalProgress progress("acquire");
  FrozenWatch frozen(map.devices.size());
  const auto t0 = std::chrono::steady_clock::now();
  while (g_signal == 0 && !session.fatal()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const auto status = session.status();
    frozen.check(status, progress);
    progress.update(o.duration_s > 0 ? std::min(1.0, el / o.duration_s) : -1.0, live_line(status));
    if (o.duration_s > 0 && el >= o.duration_s) break;
  }
  session.stop();
  const auto status = session.status();  // after stop: includes the last polls
  progress.finish(live_line(status));
  if (const auto f = session.fatal())
    throw std::runtime_error(fmt::format("ACQUISITION STOPPED: {}. The journal {} holds what was synced; "
                                         "run `burrbench recover` on it.", *f, journal.string()));
  return status;
}

// Nothing was acquired: no recording is written (an empty one would pass for data)
// and the journal, holding only events, goes. Says why, from the devices' own events.
void report_nothing_acquired(const burrbench::rig::JournalContents& contents, const burrbench::rig::SessionStatus& status,
                             const Options& o, const std::filesystem::path& journal) {
  using namespace burrbench;
  std::string why = "no fault was logged";
  for (const auto& e : contents.events)
    if (e.kind != "start" && e.kind != "stop" && e.kind != "realtime") {
      why = e.kind + ": " + e.detail;
      break;
    }
  if (!o.keep_journal) std::filesystem::remove(journal);
  std::cerr << fmt::format("burrbench: acquire: no device delivered a sample in {:.1f} s ({}); "
                           "nothing was written\n", status.elapsed_s, why);
  apps::set_exit_code(1);
}

// The recording from the journal, written to --out (the journal kept when that fails).
burrbench::data_schema::Recording write_recording_from(const burrbench::rig::JournalContents& contents, const Options& o,
                                                        const std::filesystem::path& journal,
                                                        burrbench::rig::FinaliseReport& rep) {
  using namespace burrbench;
  const std::filesystem::path out(o.out);
  // The --out check ran before the session; a file that appeared since is not replaced.
  if (!o.overwrite && std::filesystem::exists(out))
    throw std::runtime_error(fmt::format("{} appeared during the session and is kept; the session is in the journal {}: "
                                         "run `burrbench recover {} --out OTHER.h5`", o.out, journal.string(), journal.string()));
  auto rec = rig::recording_from_journal(contents, journal.string(), &rep);
  for (const auto& p : rep.problems) std::cerr << "warning: " << p << "\n";
  std::vector<std::filesystem::path> inputs{o.rig};
  if (!o.tare.empty()) inputs.emplace_back(o.tare);
  rec.provenance = make_provenance(inputs);
  data_schema::validate(rec, journal.string());  // a defect is the journal's (kept for recover)
  try {
    data_schema::write_recording(out, rec);
  } catch (const std::runtime_error& e) {
    // A full disk at the very end: the session is safe in the journal; say so, and how.
    if (typeid(e) != typeid(std::runtime_error)) throw;
    throw std::runtime_error(fmt::format("{}; the session is kept in the journal {}: run `burrbench recover {} --out {}` "
                                         "once the cause is fixed",
                                         e.what(), journal.string(), journal.string(), o.out));
  }
  if (!o.keep_journal) std::filesystem::remove(journal);
  return rec;
}

// What was written, the devices' table, and every record lost or thread without
// real-time priority as a warning of its own.
void print_session(const burrbench::rig::SessionStatus& status, const burrbench::rig::FinaliseReport& rep,
                   const burrbench::data_schema::Recording& rec, const Options& o) {
  std::cout << fmt::format("wrote {}: {:.1f} s, {} samples ({} stale, {} with invalid values), {} events\n",
                           o.out, status.elapsed_s, rep.samples, rep.stale, rep.invalid, rec.events.size());
  std::cout << fmt::format("{:<14} {:>9} {:>9} {:>10} {:>12} {:>9} {:>8} {:>10} {:>7} {:>7}\n", "device", "req Hz",
                           "got Hz", "samples", "jitter p99", "timeouts", "errors", "reconnects", "missed", "lost");
  for (const auto& d : status.devices)
    if (d.samples == 0) std::cerr << fmt::format("warning: device {} delivered no sample (see the recording's events)\n", d.name);
  for (const auto& d : status.devices)
    std::cout << fmt::format("{:<14} {:>9.1f} {:>9.1f} {:>10} {:>9.0f} µs {:>9} {:>8} {:>10} {:>7} {:>7}\n", d.name,
                             d.rate_hz, d.achieved_hz, d.samples, d.jitter_p99_us, d.timeouts, d.errors, d.reconnects,
                             d.missed_polls, d.fifo ? std::to_string(d.lost) : std::string("-"));
  // Records lost are never only a number in a table: one line each, on stderr with the
  // other warnings (scripts/demo repeats them in its summary).
  for (const auto& d : status.devices)
    if (d.fifo && d.lost > 0)
      std::cerr << fmt::format("warning: {} lost {} of {} FIFO records in {} overrun(s): the device's FIFO overflowed "
                               "before a poll took them (gap events in the recording; docs/rig.md, \"A loaded host\")\n",
                               d.name, d.lost, d.samples + d.lost, d.overruns);
  if (status.realtime_denied > 0)
    std::cerr << fmt::format("note: {} of {} acquisition threads ran without real-time priority ({}); on a busy host "
                             "FIFO records may be lost: docs/rig.md, \"A loaded host\"\n",
                             status.realtime_denied, status.threads, status.realtime_reason);
}

// acquire --watch: the live view follows the journal this session writes, on a thread of
// its own below the acquisition's (watch/background.hpp); bad watch inputs stop here.
std::unique_ptr<burrbench::watch::BackgroundWatch> start_watch(const Options& o, const std::filesystem::path& journal) {
  using namespace burrbench;
  if (o.watch.empty()) return nullptr;
  if (o.watch_recording.empty() || o.watch_params.empty())
    throw InputError("--watch", "--watch-recording, --watch-params", "both given with --watch");
  watch::WatchOptions w;
  w.experiment = o.watch;
  w.recording_id = o.watch_recording;
  w.params = o.watch_params;
  w.fit = o.watch_fit;
  w.journal = journal;
  w.server.bind = o.watch_bind;
  if (!watch::is_loopback(w.server.bind))
    std::cerr << fmt::format("WARNING: --watch-bind {}: the page is served beyond this host (read-only)\n", w.server.bind);
  w.on_url = [](const std::string& url) { std::cout << "watch: open " << url << std::endl; };
  w.say = [](const std::string& line) { std::cerr << line << std::endl; };
  return std::make_unique<watch::BackgroundWatch>(std::move(w));
}

void run(const Options& o) {
  using namespace burrbench;
  const auto map = rig::load_rig_map(o.rig);
  const std::filesystem::path journal = o.journal.empty() ? std::filesystem::path(o.out + ".journal") : std::filesystem::path(o.journal);
  refuse_outputs(o, journal);
  if (o.duration_s < 0) throw InputError("--duration", "value", "seconds ≥ 0");
  data_schema::RecordingMeta burr;
  o.burr.apply(burr);  // checked before the session, not after it
  const rig::SessionHeader h = session_header(o, map, burr);
  catch_stop_signals();
  const auto live = start_watch(o, journal);
  rig::Session session(map, journal, rig::to_json(h).dump());
  const auto status = acquire(session, map, o, journal);
  const auto contents = rig::read_journal(journal);
  if (contents.samples.empty()) {
    report_nothing_acquired(contents, status, o, journal);
    return;
  }
  rig::FinaliseReport rep;
  const auto rec = write_recording_from(contents, o, journal, rep);
  print_session(status, rep, rec, o);
  if (live) {
    std::string error;
    const auto summary = live->finish(30, &error);
    std::cerr << (error.empty() ? summary.text() : "watch stopped: " + error) << "\n";
  }
}

void setup(CLI::App& root) {
  auto* cmd = root.add_subcommand("acquire", "Record a drilling session from the rig (read-only Modbus polling)");
  auto o = std::make_shared<Options>();
  cmd->add_option("--rig", o->rig, "register map (TOML, see docs/rig.md)")->required();
  cmd->add_option("--out", o->out, "recording to write (HDF5)")->required();
  cmd->add_option("--duration", o->duration_s, "stop after this many seconds (default: until Ctrl-C/SIGTERM)");
  cmd->add_option("--sample-id", o->sample_id, "id of the bone sample being drilled");
  cmd->add_option("--notes", o->notes, "free text stored in the recording");
  o->burr.add_to(cmd);
  cmd->add_option("--tare", o->tare, "tare file from `burrbench rig tare` (stored as the sensor bias)");
  cmd->add_option("--journal", o->journal, "journal path (default: OUT.journal)");
  cmd->add_flag("--keep-journal", o->keep_journal, "keep the journal after the recording is written");
  cmd->add_flag("--overwrite", o->overwrite, "replace an existing --out recording (refused otherwise)");
  cmd->add_option("--watch", o->watch, "experiment manifest: serve the live view beside the acquisition (docs/watch.md)");
  cmd->add_option("--watch-recording", o->watch_recording, "with --watch: the manifest's recording id this session is");
  cmd->add_option("--watch-params", o->watch_params, "with --watch: parameter set (.toml)");
  cmd->add_option("--watch-fit", o->watch_fit, "with --watch: fit.json whose nuisances and sigma apply");
  cmd->add_option("--watch-bind", o->watch_bind, "with --watch: address to serve on")->capture_default_str();
  cmd->callback([o] { run(*o); });
}
BURRBENCH_VERB("acquire", setup);

}  // namespace
