// burrbench watch: the model follows a journal that `acquire` is writing, and a local page
// shows measured against predicted force, the residual, the burr's path and the alarms.
// The work is the watch library's (watch/, docs/watch.md); this file is its options.
#include <fmt/format.h>

#include <atomic>
#include <csignal>
#include <iostream>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/watch/session.hpp"
#include "verb_registry.hpp"

namespace {

using namespace burrbench;

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop = true; }

struct Args {
  watch::WatchOptions o;
  std::string experiment, params, fit, journal;
  double step_us = 0;
};

void run(Args& a) {
  watch::WatchOptions o = a.o;
  o.experiment = a.experiment;
  o.params = a.params;
  o.fit = a.fit;
  o.journal = a.journal;
  o.live.step_s = a.step_us * 1e-6;
  if (!watch::is_loopback(o.server.bind))
    std::cerr << fmt::format(
        "WARNING: --bind {}: the page is served beyond this host; anyone on that network with the "
        "URL's token sees "
        "the session (the page is read-only)\n",
        o.server.bind);
  o.on_url = [](const std::string& url) {
    std::cout << "watch: open " << url << std::endl;  // flushed: a script reads it at once
  };
  o.say = [](const std::string& line) { std::cerr << line << std::endl; };
  o.stop = &g_stop;
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  const watch::WatchSummary s = watch::run_watch(o);
  std::cerr << s.text() << "\n";
}

void setup(CLI::App& root) {
  auto* cmd = root.add_subcommand(
      "watch",
      "Follow a journal that acquire is writing: the model's prediction beside the "
      "measured force on a local web page, with alarms (read-only)");
  auto a = std::make_shared<Args>();
  auto& o = a->o;
  cmd->add_option("EXPERIMENT,--experiment", a->experiment,
                  "experiment manifest (.toml): sample, registration, sensor")
      ->required();
  cmd->add_option("--recording", o.recording_id,
                  "the manifest's recording id the session is (its registration, segments)")
      ->required();
  cmd->add_option("--params", a->params, "parameter set (.toml), e.g. a fit's params.toml")
      ->required();
  cmd->add_option(
      "--fit", a->fit,
      "fit.json whose nuisances (lag, depth offset, pose, bias) and residual sigma apply");
  cmd->add_option("--journal", a->journal,
                  "the journal to follow (default: the recording's path + .journal, acquire's)");
  cmd->add_option("--bind", o.server.bind,
                  "address to serve on (default 127.0.0.1: this host only)")
      ->capture_default_str();
  cmd->add_option("--port", o.server.port, "port (0: a free one)")
      ->capture_default_str()
      ->check(CLI::Range(0, 65535));
  cmd->add_option("--residual-k", o.live.alarms.residual_k, "alarm band: k sigma on any axis")
      ->capture_default_str();
  cmd->add_option("--residual-hold-ms", o.live.alarms.residual_hold_ms,
                  "residual beyond the band for longer than this → alarm")
      ->capture_default_str();
  cmd->add_option("--contact-k", o.live.alarms.contact_k, "a force reads as contact above k sigma")
      ->capture_default_str();
  cmd->add_option("--contact-hold-ms", o.live.alarms.contact_hold_ms,
                  "contact predicted but not measured (or the reverse) "
                  "for longer than this → alarm")
      ->capture_default_str();
  cmd->add_option("--sigma-N", o.live.sigma_N,
                  "sensor noise sigma per axis (N; 0: the fit's, else measured without contact)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--step-us", a->step_us,
                  "replay step (µs; 0: half the first samples' median period)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--wait-s", o.wait_journal_s, "how long to wait for the journal to appear")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_flag("--exit-at-end", o.exit_at_end,
                "exit once the session ended and is replayed (default: serve until Ctrl-C)");
  cmd->callback([a] { run(*a); });
}
BURRBENCH_VERB("watch", setup);

}  // namespace
