#include "burrbench/rig/session.hpp"

#include <pthread.h>
#include <sched.h>
#include <time.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <limits>
#include <map>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/rig/decode.hpp"
#include "burrbench/rig/modbus_link.hpp"

namespace burrbench::rig {
namespace {

void sleep_until_ns(std::int64_t t) {
  // A deadline already past (back-to-back polling) needs no system call; on a virtual
  // machine each one is a trip through the hypervisor.
  if (monotonic_ns() >= t) return;
  timespec ts{static_cast<time_t>(t / 1'000'000'000), static_cast<long>(t % 1'000'000'000)};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

// Interval jitter histogram, 1 µs bins up to 100 ms.
struct JitterHist {
  std::vector<std::uint64_t> bins = std::vector<std::uint64_t>(100001, 0);
  std::uint64_t n = 0;
  double max_us = 0;
  void add(double us) {
    us = std::abs(us);
    max_us = std::max(max_us, us);
    ++bins[std::min<std::size_t>(bins.size() - 1, static_cast<std::size_t>(us))];
    ++n;
  }
  double quantile(double q) const {
    if (!n) return 0;
    const auto target = static_cast<std::uint64_t>(std::ceil(q * static_cast<double>(n)));
    std::uint64_t acc = 0;
    for (std::size_t i = 0; i < bins.size(); ++i)
      if ((acc += bins[i]) >= target) return static_cast<double>(i + 1);
    return max_us;
  }
};

}  // namespace

struct DeviceState {
  const DeviceSpec* spec = nullptr;
  std::uint16_t index = 0;
  std::int64_t period_ns = 0, next_ns = 0;
  std::int64_t last_counter = -1;   // unwrapped (decode.hpp: unwrap_counter)
  std::int64_t counter_advanced_ns = 0;  // send time of the poll that last saw it advance
  std::int64_t rate_c0 = -1, rate_t0_ns = 0;  // latest mode: counter and time seen first, for the device's rate
  std::int64_t last_ok_send_ns = -1;
  std::int64_t last_ok_before_ns = 0;  // the good poll before that (set in on_good)
  bool pending_gap = false;         // polls failed since the last good one
  std::int64_t gap_since_ns = 0;
  std::int64_t reconnect_at_ns = 0, backoff_ns = 20'000'000;
  // A run of failed polls of one kind (e.g. 3000 "busy" exceptions in 1.5 s) is one event
  // with its count and span, not one event per poll. Poller thread only.
  struct FaultRun {
    std::string kind, detail;
    std::int64_t first_ns = 0, last_ns = 0;
    std::uint64_t count = 0;
  } run;
  mutable std::mutex m;             // guards status + hist
  DeviceStatus status;
  JitterHist hist;
};

namespace {

// SCHED_FIFO for the acquisition threads, and how many of them the system refused it.
struct ThreadCensus {
  std::atomic<int> threads{0}, denied{0};
  mutable std::mutex m;
  std::string reason;  // guarded by m
  // Asks for SCHED_FIFO at `priority` for the calling thread; the reason when refused.
  std::optional<std::string> ask(int priority) {
    sched_param sp{};
    sp.sched_priority = priority;
    ++threads;
    const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
    if (rc == 0) return std::nullopt;
    ++denied;
    std::lock_guard lk(m);
    reason = std::strerror(rc);
    return fmt::format("SCHED_FIFO not available ({}); normal priority", reason);
  }
};

// The journal writer: one thread that takes what the pollers queue (samples, events), and
// every 50 ms appends it to the journal and fsyncs. A write or fsync error is fatal and
// never retried: it stops the pollers (through `stopping`) and is kept for Session::fatal.
class JournalThread {
 public:
  JournalThread(const std::filesystem::path& journal, const std::string& header_json, ThreadCensus& census,
                std::atomic<bool>& stopping)
      : journal_(std::make_unique<JournalWriter>(journal, header_json)), census_(census), stopping_(stopping) {}
  ~JournalThread() { finish(); }
  JournalThread(const JournalThread&) = delete;
  JournalThread& operator=(const JournalThread&) = delete;

  void start() { thread_ = std::thread([this] { loop(); }); }
  void push(JournalSample&& s) {
    std::lock_guard lk(qm_);
    qs_.push_back(std::move(s));
  }
  void event(int device, std::string kind, std::string detail, std::int64_t t_ns = 0) {
    std::lock_guard lk(qm_);
    qe_.push_back({t_ns ? t_ns : monotonic_ns(), device, std::move(kind), std::move(detail)});
  }
  // Writes what is queued, then (unless a write failed) the end marker. Once.
  void finish() {
    if (finishing_.exchange(true)) return;
    qcv_.notify_all();
    if (thread_.joinable()) thread_.join();
    if (fatal()) return;
    try {
      journal_->finish();
    } catch (const std::exception& e) {
      std::lock_guard lk(fm_);
      fatal_ = e.what();
    }
  }
  std::optional<std::string> fatal() const {
    std::lock_guard lk(fm_);
    return fatal_;
  }
  std::uint64_t blocks_written() const { return journal_->blocks_written(); }

 private:
  void loop() {
    if (auto why = census_.ask(10)) event(-1, "realtime", fmt::format("journal writer: {}", *why));  // below the pollers, above the busy host (optional, as below)
    std::vector<JournalSample> s;
    std::vector<JournalEvent> e;
    for (;;) {
      const bool last = finishing_.load();
      {
        std::unique_lock lk(qm_);
        qcv_.wait_for(lk, std::chrono::milliseconds(50), [&] { return finishing_.load(); });
        s.swap(qs_);
        e.swap(qe_);
      }
      try {
        for (auto& x : e) journal_->append(x);
        for (auto& x : s) journal_->append(x);
        journal_->sync();
      } catch (const std::exception& ex) {
        std::lock_guard lk(fm_);
        fatal_ = ex.what();
        stopping_ = true;  // stop loudly: the caller sees fatal()
        return;
      }
      s.clear();
      e.clear();
      if (last) return;
    }
  }

  std::unique_ptr<JournalWriter> journal_;
  ThreadCensus& census_;
  std::atomic<bool>& stopping_;
  std::atomic<bool> finishing_{false};
  std::thread thread_;
  std::mutex qm_;
  std::condition_variable qcv_;
  std::vector<JournalSample> qs_;
  std::vector<JournalEvent> qe_;
  mutable std::mutex fm_;
  std::optional<std::string> fatal_;
};

// One poller thread: a TCP device, or every device on one RS-485 bus (one request at a
// time, in deadline order). It owns its link, reads on absolute deadlines, turns replies
// into journal samples (latest values, or FIFO records by counter) and faults into events,
// and recovers through the link (ModbusLink::recover_after) without knowing its transport.
class Poller {
 public:
  Poller(std::vector<DeviceState*> group, JournalThread& journal, ThreadCensus& census, const std::atomic<bool>& stopping)
      : group_(std::move(group)), journal_(journal), census_(census), stopping(stopping) {}

 private:
  void on_good(DeviceState& st, const ReadResult& r, const std::vector<std::uint16_t>& regs) {
    const auto& d = *st.spec;
    end_run(st);
    std::lock_guard lk(st.m);
    ++st.status.polls;
    if (st.last_ok_send_ns >= 0) {
      const auto dt = r.t_send_ns - st.last_ok_send_ns;
      if (dt < 2 * st.period_ns) st.hist.add(static_cast<double>(dt - st.period_ns) * 1e-3);
    }
    const std::int64_t since_last_ns = st.last_ok_send_ns >= 0 ? r.t_send_ns - st.last_ok_send_ns : 0;
    st.last_ok_before_ns = st.last_ok_send_ns >= 0 ? st.last_ok_send_ns : r.t_send_ns;
    st.last_ok_send_ns = r.t_send_ns;
    if (d.mode == Mode::Latest) {
      std::int64_t counter = -1;
      double device_hz = 0;  // observed over at least 0.25 s, else unknown (0)
      if (st.rate_c0 >= 0 && st.last_ok_before_ns - st.rate_t0_ns > 250'000'000 && st.last_counter > st.rate_c0)
        device_hz = static_cast<double>(st.last_counter - st.rate_c0) /
                    (static_cast<double>(st.last_ok_before_ns - st.rate_t0_ns) * 1e-9);
      if (d.counter) {
        const auto raw = decode_integer(regs.data() + (d.counter->address - d.start), d.counter->type, d.counter->order);
        // How far the device can have counted: twice its observed rate over the time since
        // the last good poll (half the counter's range until its rate is known).
        double max_advance = 0.5 * static_cast<double>(counter_range(d.counter->type));
        if (device_hz > 0)
          max_advance = 2.0 * device_hz * static_cast<double>(r.t_recv_ns - st.last_ok_before_ns) * 1e-9 + 16.0;
        counter = take_counter(st, raw, d.counter->type, max_advance);
        if (st.rate_c0 < 0 || counter < st.last_counter) {
          st.rate_c0 = counter;
          st.rate_t0_ns = r.t_send_ns;
        }
      }
      // Samples the schedule would have seen are gone — say so. (A regular schedule slower
      // than the device skips counters by design; that is sampling, not loss.) Two ways:
      // the poll was sent late (overrun, stall), or it was sent on time but the device
      // answered late and so sampled late (fault 5: send times alone do not show it). The
      // second is a skip beyond what one period at the device's observed rate explains
      // (any skip when the device is no faster than the polls), or, in the first 0.25 s
      // before its rate is known, any skip while previous send → this reply spans more
      // than a period (conservative: a faster device's skips by design are flagged then).
      if (!st.pending_gap && counter >= 0 && st.last_counter >= 0 && counter - st.last_counter > 1) {
        const std::int64_t skip = counter - st.last_counter;
        const double span_ms = static_cast<double>(r.t_recv_ns - st.last_ok_before_ns) * 1e-6;
        bool lost = since_last_ns > st.period_ns * 3 / 2;
        if (device_hz > 0)
          lost = lost || skip > std::max<std::int64_t>(1, static_cast<std::int64_t>(std::floor(
                                                              device_hz * static_cast<double>(st.period_ns) * 1e-9 * 1.25)));
        else
          lost = lost || span_ms > static_cast<double>(st.period_ns) * 1e-6;  // conservative until the rate is known
        if (lost)
          event(st.index, "gap", fmt::format("late poll or late reply: {:.1f} ms since the previous request was sent; "
                                             "counter {} → {}", span_ms, st.last_counter, counter));
      }
      if (st.pending_gap) {
        event(st.index, "gap", fmt::format("no data for {:.1f} ms; counter {} → {}",
                                           (r.t_send_ns - st.gap_since_ns) * 1e-6, st.last_counter, counter));
        st.pending_gap = false;
      }
      if (counter >= 0 && st.last_counter >= 0 && counter < st.last_counter)
        event(st.index, "counter_reset", fmt::format("counter {} → {} (device restarted: it went back further than a wrap of its {}-bit range explains)",
                                                     st.last_counter, counter, register_count(d.counter->type) * 16));
      if (counter >= 0) {
        if (counter != st.last_counter) st.counter_advanced_ns = r.t_send_ns;
        st.status.frozen_s = static_cast<double>(r.t_send_ns - st.counter_advanced_ns) * 1e-9;
        st.last_counter = counter;
      }
      push({st.index, r.t_send_ns, r.t_recv_ns, counter, regs});
      ++st.status.samples;
      note_values(st, regs, d.start);
      return;
    }
    // FIFO: take every record newer than the last one taken.
    const auto& f = *d.fifo;
    // Records the device can have taken since the last good poll's request: its rate, with
    // 50 % margin, over that time and one period more.
    const double max_advance =
        f.device_rate_hz * 1.5 * (static_cast<double>(r.t_recv_ns - st.last_ok_before_ns) * 1e-9) + 2.0;
    if (f.record_counter) {
      // The newest record's own counter (its slot is in the block read first): a poll that
      // stops reading early (fifo_reached) never reads the header's counter.
      const auto& rc = *f.record_counter;
      const auto* newest_rec = regs.data() + (f.first_register - d.start) + (f.depth - 1) * f.record_registers;
      const std::int64_t newest = take_counter(st, decode_integer(newest_rec + rc.address, rc.type, rc.order), rc.type, max_advance);
      if (st.last_counter >= 0 && newest < st.last_counter) {
        event(st.index, "counter_reset", fmt::format("fifo counter {} → {} (device restarted: it went back further than a wrap of its {}-bit range explains)",
                                                     st.last_counter, newest, register_count(rc.type) * 16));
        st.last_counter = -1;  // start afresh from the newest record
      }
      take_counted_records(st, r, regs, newest);
      return;
    }
    const auto raw = decode_integer(regs.data() + (f.counter.address - d.start), f.counter.type, f.counter.order);
    const std::int64_t newest = take_counter(st, raw, f.counter.type, max_advance);
    std::int64_t from = newest;  // first poll or after a reset: the newest record only
    if (st.last_counter >= 0 && newest >= st.last_counter) {
      from = st.last_counter + 1;
      const std::int64_t oldest = newest - f.depth + 1;
      if (from < oldest) {
        event(st.index, "gap", fmt::format("fifo overrun: counter {} → {}, {} records lost", st.last_counter, oldest, oldest - from));
        ++st.status.overruns;
        st.status.lost += static_cast<std::uint64_t>(oldest - from);
        from = oldest;
      }
    } else if (st.last_counter >= 0) {
      event(st.index, "counter_reset", fmt::format("fifo counter {} → {} (device restarted: it went back further than a wrap of its {}-bit range explains)",
                                                   st.last_counter, newest, register_count(f.counter.type) * 16));
    }
    if (st.pending_gap) {
      event(st.index, "reconnect_gap", fmt::format("no poll for {:.1f} ms, fifo resumed at record {}",
                                                   (r.t_send_ns - st.gap_since_ns) * 1e-6, from));
      st.pending_gap = false;
    }
    const int first_off = f.first_register - d.start;
    for (std::int64_t c = from; c <= newest; ++c) {
      const auto slot = static_cast<int>(f.depth - 1 - (newest - c));
      const auto* rec = regs.data() + first_off + slot * f.record_registers;
      std::vector<std::uint16_t> one(rec, rec + f.record_registers);
      note_values(st, one, 0);
      push({st.index, r.t_send_ns, r.t_recv_ns, c, std::move(one)});
      ++st.status.samples;
    }
    st.last_counter = newest;
  }

  // FIFO records that carry their own counters (FifoSpec::record_counter), read in several
  // blocks: the window may have moved between two requests, so a record is known by its
  // counter, not its slot. Taken in counter order from last_counter + 1 while they follow
  // one another, up to the newest record of the poll's first request (its newest block):
  // so each record taken was held before that reply, which is the t_recv the records get
  // (the clock fit's bound; later blocks only repeat or add records newer than it, which
  // wait for the next poll). At a hole the rest waits too (still in the FIFO), unless the
  // hole is older than every record the FIFO still holds: then it is an overrun.
  void take_counted_records(DeviceState& st, const ReadResult& r, const std::vector<std::uint16_t>& regs,
                            std::int64_t newest) {
    const auto& d = *st.spec;
    const auto& f = *d.fifo;
    const auto& rc = *f.record_counter;
    const std::int64_t range = counter_range(rc.type);
    const int first_off = f.first_register - d.start;
    std::map<std::int64_t, int> slot_of;  // unwrapped record counter → slot
    std::int64_t oldest_held = std::numeric_limits<std::int64_t>::max();
    // Slots the poll's first request read: the last block's (ModbusLink reads newest first).
    const int first_slot = (d.count - d.blocks.back().count - first_off + f.record_registers - 1) / f.record_registers;
    // Slots this poll read at all: from the oldest block it reached (fifo_reached) up.
    const auto lowest_block = d.blocks.size() - std::min(d.blocks.size(), std::max<std::size_t>(1, r.blocks_read));
    const int lowest_slot = fifo_slots(d, lowest_block).first;
    std::int64_t newest_first = -1;
    for (int slot = lowest_slot; slot < f.depth; ++slot) {
      const auto* rec = regs.data() + first_off + slot * f.record_registers;
      const std::int64_t raw = decode_integer(rec + rc.address, rc.type, rc.order);
      // Nearest to the header's newest counter, either side (a later block may be newer).
      std::int64_t delta = ((raw - newest) % range + range) % range;
      if (delta >= range / 2) delta -= range;
      const std::int64_t c = newest + delta;
      if (c < 0) continue;  // a slot not yet written
      slot_of.emplace(c, slot);
      oldest_held = std::min(oldest_held, c);
      if (slot >= first_slot) newest_first = std::max(newest_first, c);
    }
    std::int64_t next = st.last_counter + 1;
    if (st.last_counter < 0) next = newest_first;  // first poll: the newest only
    else if (!slot_of.count(next) && oldest_held > next && oldest_held != std::numeric_limits<std::int64_t>::max()) {
      event(st.index, "gap", fmt::format("fifo overrun: counter {} → {}, {} records lost", st.last_counter,
                                         oldest_held, oldest_held - next));
      ++st.status.overruns;
      st.status.lost += static_cast<std::uint64_t>(oldest_held - next);
      next = oldest_held;
    }
    if (st.pending_gap) {
      event(st.index, "reconnect_gap", fmt::format("no poll for {:.1f} ms, fifo resumed at record {}",
                                                   (r.t_send_ns - st.gap_since_ns) * 1e-6, next));
      st.pending_gap = false;
    }
    for (auto it = slot_of.find(next); it != slot_of.end() && it->first == next && next <= newest_first; ++it, ++next) {
      const auto* rec = regs.data() + first_off + it->second * f.record_registers;
      std::vector<std::uint16_t> one(rec, rec + f.record_registers);
      note_values(st, one, 0);
      push({st.index, r.t_send_ns, r.t_first_recv_ns, next, std::move(one)});
      ++st.status.samples;
    }
    st.last_counter = std::max(st.last_counter, next - 1);
  }

  // The FIFO slots wholly inside block k: [first, last).
  static std::pair<int, int> fifo_slots(const DeviceSpec& d, std::size_t k) {
    const auto& f = *d.fifo;
    int at = 0;
    for (std::size_t j = 0; j < k; ++j) at += d.blocks[j].count;
    const int from = at - (f.first_register - d.start), to = from + d.blocks[k].count;
    const int rr = f.record_registers;
    const int first = from <= 0 ? 0 : (from + rr - 1) / rr;
    const int last = to <= 0 ? 0 : std::min(f.depth, to / rr);
    return {std::min(first, f.depth), last};
  }

  // A FIFO with record counters is read from its newest block down only as far as the poll
  // needs: to the block that holds the record after the last one taken (or one older), and
  // at the first poll, or after a counter reset, the newest block alone. In the steady state a
  // poll is then a few requests, not one per block (at 1 kHz and 50 polls/s the force
  // sensor's 20 new records are in 3 of its 12 blocks), so a loaded host or device answers
  // it before the window moves past the records it still needs; after a stall it reads as
  // far back as the stall asks. true: block k (just read) reaches back far enough.
  static bool fifo_reached(const DeviceState& st, const std::vector<std::uint16_t>& regs, std::size_t k) {
    const auto& d = *st.spec;
    if (st.last_counter < 0) return true;
    const auto& f = *d.fifo;
    const auto& rc = *f.record_counter;
    const std::int64_t range = counter_range(rc.type);
    const std::int64_t want = (st.last_counter + 1) % range;
    const int first_off = f.first_register - d.start;
    const auto [first, last] = fifo_slots(d, k);
    for (int slot = first; slot < last; ++slot) {
      const auto* rec = regs.data() + first_off + slot * f.record_registers;
      std::int64_t delta = ((decode_integer(rec + rc.address, rc.type, rc.order) - want) % range + range) % range;
      if (delta >= range / 2) delta -= range;
      if (delta <= 0) return true;  // this record is the one wanted, or older
    }
    return false;
  }

  // The unwrapped counter; after a restart (unwrap_counter gives nothing) the raw value
  // modulo the range, so the caller sees it below the last one and logs a counter_reset.
  static std::int64_t take_counter(const DeviceState& st, std::int64_t raw, ValueType type, double max_advance) {
    if (const auto c = unwrap_counter(st.last_counter, raw, type, max_advance)) return *c;
    const std::int64_t range = counter_range(type);
    return ((raw % range) + range) % range;
  }

  static void note_values(DeviceState& st, const std::vector<std::uint16_t>& regs, int base) {
    const auto& ch = st.spec->channels.front();
    st.status.last.resize(ch.registers.size());
    const bool values_ok = decode_channel(ch, regs, base, st.status.last);
    if (!values_ok || status_invalid(*st.spec, regs, base)) ++st.status.invalid;
  }

  void on_bad(DeviceState& st, ModbusLink& link, const ReadResult& r) {
    {
      std::lock_guard lk(st.m);
      if (r.status == ReadStatus::Timeout) ++st.status.timeouts;
      else ++st.status.errors;
      if (!st.pending_gap) {
        st.pending_gap = true;
        st.gap_since_ns = r.t_send_ns;
      }
    }
    if (r.status != ReadStatus::Disconnected || link.connected())
      fault(st, to_string(r.status), r.detail, r.t_send_ns);
    if (link.recover_after(*st.spec, r, &stopping)) {
      // The first retry is immediate, not at the next deadline: a dropped connection to a
      // live device costs one round trip, not a poll period.
      st.reconnect_at_ns = monotonic_ns();
      st.backoff_ns = backoff_first_ns(*st.spec);
      try_reconnect(st, link);
    }
  }

  void try_reconnect(DeviceState& st, ModbusLink& link) {
    const auto now = monotonic_ns();
    if (now < st.reconnect_at_ns) return;
    std::string err;
    if (link.connect(&err)) {
      {
        std::lock_guard lk(st.m);
        ++st.status.reconnects;
      }
      end_run(st);
      event(st.index, "reconnect", link.describe());
      st.backoff_ns = backoff_first_ns(*st.spec);
    } else {
      st.reconnect_at_ns = now + st.backoff_ns;
      st.backoff_ns = std::min<std::int64_t>(st.backoff_ns * 2, static_cast<std::int64_t>(st.spec->reconnect_max_ms * 1e6));
    }
  }
  static std::int64_t backoff_first_ns(const DeviceSpec& d) {
    return static_cast<std::int64_t>(d.reconnect_backoff_ms * 1e6);
  }

 public:
  // The thread's body: until `stopping`, poll the group's devices at their deadlines.
  void run() {
    auto& group = group_;
    // Real-time priority keeps the period tight on a busy host; the thread sleeps between
    // deadlines and blocks on I/O, so it cannot starve the machine. Optional: without
    // the privilege we poll at normal priority and say so.
    if (auto why = census_.ask(20)) event(group_.front()->index, "realtime", fmt::format("poller: {}", *why));
    ModbusLink link(*group.front()->spec);
    std::string err;
    if (!link.connect(&err)) event(group.front()->index, "fault", err);
    std::vector<std::uint16_t> regs;
    while (!stopping.load()) {
      auto* st = *std::min_element(group.begin(), group.end(), [](auto* a, auto* b) { return a->next_ns < b->next_ns; });
      sleep_until_ns(st->next_ns);
      if (stopping.load()) break;
      st->next_ns += st->period_ns;
      // Overrun: skip deadlines already past instead of bursting to catch up.
      const auto now = monotonic_ns();
      if (now > st->next_ns) {
        const auto skip = (now - st->next_ns) / st->period_ns + 1;
        st->next_ns += skip * st->period_ns;
        std::lock_guard lk(st->m);
        st->status.missed_polls += static_cast<std::uint64_t>(skip);
      }
      if (!link.connected()) {
        try_reconnect(*st, link);
        if (!link.connected()) {
          std::lock_guard lk(st->m);
          ++st->status.missed_polls;
          if (!st->pending_gap) {
            st->pending_gap = true;
            st->gap_since_ns = now;
          }
          continue;
        }
      }
      const auto& spec = *st->spec;
      const bool partial = spec.fifo && spec.fifo->record_counter && spec.blocks.size() > 1;
      const auto r = partial ? link.read(spec, regs, [&](std::size_t k) { return fifo_reached(*st, regs, k); })
                             : link.read(spec, regs);
      if (r.status == ReadStatus::Ok) on_good(*st, r, regs);
      else on_bad(*st, link, r);
    }
    for (auto* st : group) end_run(*st);
    link.close();
  }

  static std::int64_t first_backoff_ns(const DeviceSpec& d) { return backoff_first_ns(d); }

 private:
  void push(JournalSample&& s) { journal_.push(std::move(s)); }
  void event(int device, std::string kind, std::string detail, std::int64_t t_ns = 0) {
    journal_.event(device, std::move(kind), std::move(detail), t_ns);
  }

  // Runs end at a good poll, a fault of another kind, the stop, or after 1 s (so a
  // journal cut short by a crash still holds runs older than a second).
  static constexpr std::int64_t kMaxRunNs = 1'000'000'000;
  void fault(DeviceState& st, const std::string& kind, const std::string& detail, std::int64_t t_ns) {
    auto& run = st.run;
    if (run.count && (run.kind != kind || t_ns - run.first_ns >= kMaxRunNs)) end_run(st);
    if (!run.count) {
      run.kind = kind;
      run.detail = detail;
      run.first_ns = t_ns;
    }
    run.last_ns = t_ns;
    ++run.count;
  }
  void end_run(DeviceState& st) {
    auto& run = st.run;
    if (!run.count) return;
    if (run.count == 1)
      event(st.index, run.kind, run.detail, run.first_ns);
    else
      event(st.index, run.kind,
            fmt::format("{} in a row over {:.1f} ms (last at t = {} ns); the first: {}", run.count,
                        static_cast<double>(run.last_ns - run.first_ns) * 1e-6, run.last_ns, run.detail),
            run.first_ns);
    run.count = 0;
  }

  std::vector<DeviceState*> group_;
  JournalThread& journal_;
  ThreadCensus& census_;
  const std::atomic<bool>& stopping;
};

}  // namespace

struct Session::Impl {
  RigMap map;
  std::vector<std::unique_ptr<DeviceState>> devices;
  std::atomic<bool> stopping{false};
  ThreadCensus census;
  std::unique_ptr<JournalThread> journal;
  std::vector<std::unique_ptr<Poller>> pollers;
  std::vector<std::thread> threads;
  std::int64_t start_ns = 0;
  bool stopped = false;
};

Session::Session(RigMap map, const std::filesystem::path& journal, const std::string& header_json)
    : impl_(std::make_unique<Impl>()) {
  auto& I = *impl_;
  I.map = std::move(map);
  I.journal = std::make_unique<JournalThread>(journal, header_json, I.census, I.stopping);
  I.start_ns = monotonic_ns();
  for (std::size_t i = 0; i < I.map.devices.size(); ++i) {
    auto st = std::make_unique<DeviceState>();
    st->spec = &I.map.devices[i];
    st->index = static_cast<std::uint16_t>(i);
    st->period_ns = static_cast<std::int64_t>(std::llround(1e9 / st->spec->rate_hz));
    st->next_ns = I.start_ns + 20'000'000;
    st->backoff_ns = Poller::first_backoff_ns(*st->spec);
    st->status.name = st->spec->name;
    st->status.rate_hz = st->spec->rate_hz;
    st->status.first_channel = st->spec->channels.front().name;
    st->status.fifo = st->spec->mode == Mode::Fifo;
    I.devices.push_back(std::move(st));
  }
  I.journal->event(-1, "start", fmt::format("{} device(s)", I.devices.size()));
  I.journal->start();
  // One poller per line (ModbusLink::line): a TCP device's own connection, or an RS-485
  // bus shared by its devices; in the order the map first names them.
  std::vector<std::pair<std::string, std::vector<DeviceState*>>> lines;
  for (auto& st : I.devices) {
    const std::string line = ModbusLink::line(*st->spec);
    auto it = std::find_if(lines.begin(), lines.end(), [&](const auto& l) { return l.first == line; });
    if (it == lines.end()) lines.push_back({line, {st.get()}});
    else it->second.push_back(st.get());
  }
  for (auto& [line, group] : lines) {
    I.pollers.push_back(std::make_unique<Poller>(group, *I.journal, I.census, I.stopping));
    I.threads.emplace_back([p = I.pollers.back().get()] { p->run(); });
  }
}

Session::~Session() { stop(); }

SessionStatus Session::status() const {
  SessionStatus s;
  s.elapsed_s = static_cast<double>(monotonic_ns() - impl_->start_ns) * 1e-9;
  for (const auto& st : impl_->devices) {
    std::lock_guard lk(st->m);
    auto d = st->status;
    d.jitter_p99_us = st->hist.quantile(0.99);
    d.jitter_max_us = st->hist.max_us;
    d.achieved_hz = s.elapsed_s > 0 ? static_cast<double>(d.polls) / s.elapsed_s : 0;
    s.devices.push_back(std::move(d));
  }
  s.journal_blocks = impl_->journal->blocks_written();
  s.threads = impl_->census.threads.load();
  s.realtime_denied = impl_->census.denied.load();
  std::lock_guard lk(impl_->census.m);
  s.realtime_reason = impl_->census.reason;
  return s;
}

std::optional<std::string> Session::fatal() const { return impl_->journal->fatal(); }

void Session::stop() {
  auto& I = *impl_;
  if (I.stopped) return;
  I.stopped = true;
  I.stopping = true;
  for (auto& t : I.threads) t.join();
  I.threads.clear();
  I.journal->event(-1, "stop", "");
  I.journal->finish();
}

}  // namespace burrbench::rig
