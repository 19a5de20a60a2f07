#pragma once
// `burrbench watch` (and `acquire --watch`) as a short list of stages: load the model,
// serve the page, then follow the journal — poll, replay, judge, publish — until the
// session ends or the operator stops.
#include <atomic>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>

#include "burrbench/watch/live_model.hpp"
#include "burrbench/watch/server.hpp"

namespace burrbench::watch {

struct WatchOptions {
  std::filesystem::path experiment, params, fit;  // fit: optional
  std::string recording_id;
  std::filesystem::path journal;  // empty: the recording's path + ".journal" (acquire's)
  LiveSettings live;
  ServerOptions server;
  double poll_ms = 100;        // how often the journal is read
  double wait_journal_s = 60;  // how long a journal that does not exist yet is waited for
  bool exit_at_end = false;    // return once the session ended and all of it is replayed
  // Printed once the page is served (the URL with its token).
  std::function<void(const std::string& url)> on_url;
  // One line each (alarms, falling behind, the end): the terminal.
  std::function<void(const std::string& line)> say;
  const std::atomic<bool>* stop = nullptr;  // set by a signal handler
};

struct WatchSummary {
  std::size_t samples = 0, alarms = 0, events = 0;
  double max_behind_s = 0;   // the most the replay was behind the journal
  double replay_wall_s = 0;  // the time the replay took
  double session_s = 0;      // recording time replayed
  bool ended = false;        // the journal's session ended
  std::string text() const;  // one line
};

WatchSummary run_watch(const WatchOptions& options);

// Which points the page gets while the replay is `behind_s` behind the journal: every one
// up to half a second behind, else every n-th, n = ⌈2 × behind_s⌉ (the replay itself takes
// every sample; only the display is thinned until it has caught up).
std::size_t display_every(double behind_s);

// The page: watch/page/watch.html with its script and uPlot (from the report's assets,
// analysis::default_assets_dir()) inlined. InputError naming a missing file.
std::string watch_page_html();

}  // namespace burrbench::watch
