#include "burrbench/watch/session.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>
#include <thread>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/manifest.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/watch/follower.hpp"

namespace burrbench::watch {
namespace fs = std::filesystem;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

std::string WatchSummary::text() const {
  return fmt::format(
      "watch: {} samples replayed ({:.1f} s of recording in {:.1f} s), {} alarm(s), {} event(s), "
      "at most {:.2f} s behind the journal{}",
      samples, session_s, replay_wall_s, alarms, events, max_behind_s,
      ended ? "; the session ended" : "");
}

std::size_t display_every(double behind_s) {
  return behind_s > 0.5 ? std::size_t(std::ceil(2 * behind_s)) : 1;
}

namespace {

// Most of what a page needs once: the sample's top view (the largest bone fraction down
// each column, 0–255, at most ~160 columns wide) and the settings.
json hello(const LiveModel& live, const WatchOptions& o) {
  const auto& s = live.sample();
  const std::size_t f = std::max<std::size_t>(1, (std::max(s.dims[0], s.dims[1]) + 159) / 160);
  const std::size_t nx = (s.dims[0] + f - 1) / f, ny = (s.dims[1] + f - 1) / f;
  std::vector<int> top(nx * ny, 0);
  for (std::size_t z = 0; z < s.dims[2]; ++z)
    for (std::size_t y = 0; y < s.dims[1]; ++y)
      for (std::size_t x = 0; x < s.dims[0]; ++x) {
        const std::size_t i = s.index(x, y, z);
        if (s.labels[i] == 0) continue;
        int& t = top[(x / f) + nx * (y / f)];
        t = std::max(t, int(std::lround(255.0 * s.fraction[i])));
      }
  const auto& a = o.live.alarms;
  return {{"type", "hello"},
          {"recording", live.ref().id},
          {"journal", o.journal.string()},
          {"top",
           {{"nx", nx},
            {"ny", ny},
            {"origin_mm", {s.origin_mm.x, s.origin_mm.y}},
            {"cell_mm", s.voxel_mm * double(f)},
            {"values", top}}},
          {"alarms",
           {{"residual_k", a.residual_k},
            {"residual_hold_ms", a.residual_hold_ms},
            {"contact_k", a.contact_k},
            {"contact_hold_ms", a.contact_hold_ms}}}};
}

// One SSE message per poll: the new points, every `every`-th one when behind (the replay
// itself never skips a sample), the last one always.
json batch(const LiveStep& st, const LiveModel& live, std::size_t every, double behind_s) {
  json pts = json::array();
  for (std::size_t i = 0; i < st.points.size(); ++i) {
    const LivePoint& p = st.points[i];
    if (i + 1 != st.points.size() && p.index % every != 0) continue;
    pts.push_back({p.index,
                   p.t_s,
                   p.wall_ms,
                   p.measured_N.x,
                   p.measured_N.y,
                   p.measured_N.z,
                   p.predicted_N.x,
                   p.predicted_N.y,
                   p.predicted_N.z,
                   p.depth_b_mm,
                   p.centre_vol_mm.x,
                   p.centre_vol_mm.y,
                   p.centre_vol_mm.z,
                   p.torque_measured_Nmm.x,
                   p.torque_measured_Nmm.y,
                   p.torque_measured_Nmm.z,
                   p.torque_predicted_Nmm.x,
                   p.torque_predicted_Nmm.y,
                   p.torque_predicted_Nmm.z,
                   p.spindle_measured_Nmm,
                   p.spindle_predicted_Nmm});  // NaN (not logged) → null
  }
  return {{"type", "batch"},
          {"points", pts},
          {"sigma_N", live.band_known() ? live.sigma_N() : 0.0},
          {"behind_s", behind_s},
          {"every", every},
          {"sigma_source", live.sigma_source()}};
}

struct Loop {
  const WatchOptions& o;
  LiveModel& live;
  Feed& feed;
  WatchSummary sum;
  bool told_behind = false, told_band = false;
  std::size_t waiting = 0;  // force samples recorded, not replayed yet

  void say(const std::string& line) const {
    if (o.say) o.say(line);
  }
  void events(const FollowUpdate& u) {
    for (const auto& e : u.new_events) {
      ++sum.events;
      // The recording has one stream per device of the map, in its order.
      const auto& streams = u.recording ? u.recording->streams : std::vector<data_schema::Stream>{};
      const std::string stream = e.device >= 0 && std::size_t(e.device) < streams.size()
                                     ? streams[std::size_t(e.device)].name
                                     : (e.device < 0 ? "session" : std::to_string(e.device));
      feed.publish(json{
          {"type", "event"},
          {"t_ns", e.t_ns},
          {"stream", stream},
          {"kind", e.kind},
          {"detail",
           e.detail}}.dump());
    }
    for (const auto& p : u.new_problems) {
      say("watch: journal " + p);
      feed.publish(json{
          {"type", "event"},
          {"kind", "journal_damage"},
          {"detail", p},
          {"stream", "journal"},
          {"t_ns", 0}}.dump());
    }
  }
  // Replays what the poll brought, in pieces, for at most one poll period; what is left
  // waits for the next poll (the journal is read again anyway).
  void replay(const data_schema::Recording& rec) {
    const auto until = Clock::now() + std::chrono::duration<double, std::milli>(o.poll_ms);
    LiveStep st;
    do {
      const auto t0 = Clock::now();
      st = live.advance(rec, 2000);
      sum.replay_wall_s += std::chrono::duration<double>(Clock::now() - t0).count();
      const double behind_s = st.recorded_to_s - st.replayed_to_s;
      sum.max_behind_s = std::max(sum.max_behind_s, behind_s);
      // Behind by more than half a second: the page gets every n-th point until caught up.
      const std::size_t every = display_every(behind_s);
      if (every > 1 && !told_behind)
        say(
            fmt::format("watch: the replay is {:.1f} s behind the journal; the page shows every "
                        "{}th sample until it "
                        "catches up (every sample is replayed)",
                        behind_s, every));
      if (every == 1 && told_behind) say("watch: caught up with the journal");
      told_behind = every > 1;
      if (!st.points.empty()) feed.publish(batch(st, live, every, behind_s).dump());
      if (live.band_known() && !told_band) {
        told_band = true;
        say(
            fmt::format("watch: alarms armed (by t = {:.3f} s): sigma {:.3g} N ({}), bias [{:.3g}, "
                        "{:.3g}, {:.3g}] N ({})",
                        st.replayed_to_s, live.sigma_N(), live.sigma_source(), live.bias_N().x,
                        live.bias_N().y, live.bias_N().z, live.bias_source()));
      }
      for (const Alarm& a : st.alarms) {
        ++sum.alarms;
        say(fmt::format("ALARM t = {:.3f} s: {}", a.t_s, a.message));
        feed.publish(json{
            {"type", "alarm"},
            {"t_s", a.t_s},
            {"since_s", a.since_s},
            {"kind", a.kind},
            {"message",
             a.message}}.dump());
      }
      sum.samples = live.replayed();
      sum.session_s = st.replayed_to_s;
      waiting = st.waiting;
    } while (st.waiting > 0 && !st.points.empty() && Clock::now() < until);
  }
};

fs::path journal_of(const WatchOptions& o, const LiveModel& live) {
  return o.journal.empty() ? fs::path(live.ref().path.string() + ".journal") : o.journal;
}

}  // namespace

WatchSummary run_watch(const WatchOptions& opt) {
  // Stage 1: the model, from the experiment's manifest, sample and constants.
  const auto manifest = read_manifest_while_acquiring(opt.experiment, opt.recording_id);
  const auto params = data_schema::read_params(opt.params);
  std::optional<data_schema::FitResult> fit;
  if (!opt.fit.empty()) fit = data_schema::read_fit(opt.fit);
  LiveModel live(manifest, opt.recording_id, params, fit, opt.live);
  WatchOptions o = opt;
  o.journal = journal_of(opt, live);
  // Stage 2: the page.
  Feed feed;
  ServerOptions so = o.server;
  so.page_html = watch_page_html();
  WatchServer server(feed, so);
  feed.publish_first(hello(live, o).dump());
  if (o.on_url) o.on_url(server.url());
  // Stage 3: follow the journal.
  JournalFollower follower(o.journal);
  Loop loop{o, live, feed, {}};
  const auto started = Clock::now();
  bool present = false, told_slow = false;
  // The newest recording read: acquire removes its journal once done, and what was not
  // replayed by then is replayed from here.
  std::optional<data_schema::Recording> rec;
  for (;;) {
    const auto tick = Clock::now();
    if (o.stop && o.stop->load()) break;
    FollowUpdate u = follower.poll();
    const double read_ms = std::chrono::duration<double, std::milli>(Clock::now() - tick).count();
    present = present || u.present;
    if (!present && std::chrono::duration<double>(tick - started).count() > o.wait_journal_s)
      throw InputError(
          o.journal.string(), "(journal)",
          fmt::format("a journal that acquire writes, within {:g} s", o.wait_journal_s),
          "it did not appear");
    loop.events(u);
    if (u.recording) rec = std::move(u.recording);
    if (rec) loop.replay(*rec);
    const bool done = u.ended && loop.waiting == 0;
    if (done && !loop.sum.ended) {
      loop.sum.ended = true;
      feed.publish(json{{"type", "status"}, {"ended", true}, {"samples", live.replayed()}}.dump());
      loop.say("watch: the session ended; " +
               std::string(o.exit_at_end ? "done" : "the page stays until Ctrl-C"));
    }
    if (done && o.exit_at_end) break;
    // Each poll reads and decodes the whole journal (about 2 ms per second of a 1 kHz
    // session on the development VM): the period grows with it so that reading takes at
    // most a third of a core, and the latency grows instead (docs/watch.md "Cost").
    const double period_ms = std::max(o.poll_ms, 3 * read_ms);
    if (period_ms > 2.5 * o.poll_ms && !told_slow) {
      told_slow = true;
      loop.say(
          fmt::format("watch: reading the journal takes {:.0f} ms now; polling every {:.0f} ms, so "
                      "the page lags "
                      "more as the session grows (docs/watch.md \"Cost\")",
                      read_ms, period_ms));
    }
    std::this_thread::sleep_until(tick + std::chrono::duration<double, std::milli>(period_ms));
  }
  server.stop();
  return loop.sum;
}

}  // namespace burrbench::watch
