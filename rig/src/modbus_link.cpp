#include "burrbench/rig/modbus_link.hpp"

#include <sys/select.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <thread>

#include <fmt/format.h>
#include <modbus/modbus.h>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::rig {

std::int64_t monotonic_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

const char* to_string(ReadStatus s) {
  switch (s) {
    case ReadStatus::Ok: return "ok";
    case ReadStatus::Timeout: return "timeout";
    case ReadStatus::Exception: return "exception";
    case ReadStatus::BadData: return "bad_data";
    case ReadStatus::Disconnected: return "disconnected";
    case ReadStatus::EarlyReply: return "early_reply";
  }
  BURRBENCH_UNREACHABLE();
}

ModbusLink::ModbusLink(const DeviceSpec& s) : settings_(s) {
  if (s.transport == Transport::Tcp) {
    // _pi resolves host names; plain modbus_new_tcp takes dotted IPv4 only.
    ctx_ = modbus_new_tcp_pi(s.host.c_str(), std::to_string(s.port).c_str());
  } else {
    ctx_ = modbus_new_rtu(s.serial.c_str(), s.baud, s.parity, s.data_bits, s.stop_bits);
  }
  if (!ctx_) throw InputError(describe(), "device", "settings libmodbus accepts", modbus_strerror(errno));
  modbus_set_error_recovery(ctx_, MODBUS_ERROR_RECOVERY_NONE);
  const auto us = static_cast<std::uint32_t>(s.timeout_ms * 1000.0);
  modbus_set_response_timeout(ctx_, us / 1'000'000, us % 1'000'000);
  modbus_set_byte_timeout(ctx_, us / 1'000'000, us % 1'000'000);
}

ModbusLink::~ModbusLink() {
  close();
  if (ctx_) modbus_free(ctx_);
}

std::string ModbusLink::line(const DeviceSpec& d) {
  return d.transport == Transport::Rtu ? "rtu " + d.serial : "tcp device " + d.name;
}

std::string ModbusLink::describe() const {
  return settings_.transport == Transport::Tcp
             ? fmt::format("tcp {}:{}", settings_.host, settings_.port)
             : fmt::format("rtu {} {} {}{}{}", settings_.serial, settings_.baud, settings_.data_bits,
                           settings_.parity, settings_.stop_bits);
}

bool ModbusLink::connect(std::string* error) {
  close();
  if (modbus_connect(ctx_) != 0) {
    if (error) *error = fmt::format("{}: connect: {}", describe(), modbus_strerror(errno));
    modbus_close(ctx_);
    return false;
  }
  // libmodbus waits with select(): a descriptor beyond FD_SETSIZE would corrupt memory.
  if (modbus_get_socket(ctx_) >= FD_SETSIZE) {
    if (error) *error = fmt::format("{}: descriptor {} ≥ FD_SETSIZE", describe(), modbus_get_socket(ctx_));
    modbus_close(ctx_);
    return false;
  }
  connected_ = true;
  return true;
}

void ModbusLink::close() {
  if (ctx_ && connected_) modbus_close(ctx_);
  connected_ = false;
}

double ModbusLink::wire_time_s(const DeviceSpec& d) const {
  // Devices on one bus share its line settings (the map checks it).
  return settings_.transport == Transport::Rtu ? rtu_frames_wire_s(d) : 0.0;
}

ReadResult ModbusLink::read(const DeviceSpec& d, std::vector<std::uint16_t>& regs,
                            const std::function<bool(std::size_t block)>& enough) {
  regs.resize(static_cast<std::size_t>(d.count));
  if (!connected_) {
    ReadResult r;
    r.status = ReadStatus::Disconnected;
    r.t_send_ns = r.t_recv_ns = monotonic_ns();
    return r;
  }
  modbus_set_slave(ctx_, d.slave);
  // A FIFO known by its records' counters is read from its newest block down: a window
  // that moves on between two requests then repeats a record (taken once) rather than
  // skipping one (which would hold the reader back until the next poll).
  const bool newest_first = d.fifo && d.fifo->record_counter;
  std::vector<std::size_t> at(d.blocks.size(), 0);
  for (std::size_t k = 1; k < d.blocks.size(); ++k) at[k] = at[k - 1] + static_cast<std::size_t>(d.blocks[k - 1].count);
  ReadResult all;
  for (std::size_t i = 0; i < d.blocks.size(); ++i) {
    const std::size_t k = newest_first ? d.blocks.size() - 1 - i : i;
    const auto& b = d.blocks[k];
    ReadResult r = read_block(d, b, regs.data() + at[k]);
    if (i == 0) {
      all.t_send_ns = r.t_send_ns;
      all.t_first_recv_ns = r.t_recv_ns;
    }
    all.t_recv_ns = r.t_recv_ns;
    if (r.status != ReadStatus::Ok) {
      all.status = r.status;
      all.detail = d.blocks.size() > 1 ? fmt::format("block {} ({} registers from {}): {}", k, b.count, b.start, r.detail)
                                       : r.detail;
      return all;
    }
    all.blocks_read = i + 1;
    if (enough && i + 1 < d.blocks.size() && enough(k)) break;
  }
  return all;
}

ReadResult ModbusLink::read_block(const DeviceSpec& d, const BlockSpec& b, std::uint16_t* regs) {
  ReadResult r;
  // RTU: drop anything already waiting (a reply that came after we gave up on it).
  if (settings_.transport == Transport::Rtu) modbus_flush(ctx_);
  r.t_send_ns = monotonic_ns();
  std::string mismatch;
  const int rc = settings_.transport == Transport::Tcp ? read_tcp_checked(d, b, regs, &mismatch)
                 : b.function == 3 ? modbus_read_registers(ctx_, b.start, b.count, regs)
                                   : modbus_read_input_registers(ctx_, b.start, b.count, regs);
  const int err = errno;
  r.t_recv_ns = monotonic_ns();
  if (!mismatch.empty()) {
    r.status = ReadStatus::BadData;
    r.detail = mismatch;
    return r;
  }
  if (rc == b.count) {
    // A reply faster than the wire allows was already on its way: it answers an
    // earlier request, so it is not this poll's data.
    const double wire = settings_.transport == Transport::Rtu ? rtu_frames_wire_s(b, d) : 0.0;
    if (wire > 0 && static_cast<double>(r.t_recv_ns - r.t_send_ns) * 1e-9 < 0.8 * wire) {
      r.status = ReadStatus::EarlyReply;
      r.detail = fmt::format("reply after {:.2f} ms, the wire needs {:.2f} ms", (r.t_recv_ns - r.t_send_ns) * 1e-6, wire * 1e3);
    }
    return r;
  }
  r.detail = rc < 0 ? modbus_strerror(err) : fmt::format("{} registers instead of {}", rc, b.count);
  if (rc >= 0) r.status = ReadStatus::BadData;
  else if (err == ETIMEDOUT) r.status = ReadStatus::Timeout;
  else if (err > MODBUS_ENOBASE && err <= MODBUS_ENOBASE + MODBUS_EXCEPTION_GATEWAY_TARGET) r.status = ReadStatus::Exception;
  else if (err == EMBBADDATA || err == EMBBADCRC || err == EMBBADSLAVE || err == EMBBADEXC || err == EMBUNKEXC || err == EMBMDATA)
    r.status = ReadStatus::BadData;
  else r.status = ReadStatus::Disconnected;
  return r;
}

// libmodbus 3.1.6 checks a TCP reply's transaction and protocol ids but not its unit id
// (only the RTU backend compares the slave), so a gateway's reply for another unit would
// pass as this device's data. The request goes out raw (libmodbus still frames it and
// numbers it) and the reply's MBAP header and PDU are checked here.
int ModbusLink::read_tcp_checked(const DeviceSpec& d, const BlockSpec& b, std::uint16_t* regs, std::string* mismatch) {
  const std::uint8_t req[6] = {static_cast<std::uint8_t>(d.slave), static_cast<std::uint8_t>(b.function),
                               static_cast<std::uint8_t>(b.start >> 8), static_cast<std::uint8_t>(b.start & 0xff),
                               static_cast<std::uint8_t>(b.count >> 8), static_cast<std::uint8_t>(b.count & 0xff)};
  // A raw request goes out with transaction id 0 (libmodbus 3.1.6); after any failed read
  // the socket is closed (session.cpp), so no reply to an earlier request can be waiting.
  constexpr std::uint16_t tid = 0;
  if (modbus_send_raw_request(ctx_, req, 6) < 0) return -1;
  std::uint8_t rsp[MODBUS_TCP_MAX_ADU_LENGTH];
  const int n = modbus_receive_confirmation(ctx_, rsp);
  if (n < 0) return -1;
  const auto u16 = [&](int at) { return static_cast<std::uint16_t>((rsp[at] << 8) | rsp[at + 1]); };
  if (n < 9 || u16(0) != tid || u16(2) != 0) {
    *mismatch = n < 9 ? fmt::format("reply of {} bytes", n)
                      : fmt::format("reply to transaction {} (protocol {}), expected {}", u16(0), u16(2), tid);
    return -1;
  }
  if (rsp[6] != d.slave) {
    *mismatch = fmt::format("reply from unit {}, expected unit {}", rsp[6], d.slave);
    return -1;
  }
  if (rsp[7] == (b.function | 0x80)) {  // exception reply: errno as libmodbus sets it
    errno = MODBUS_ENOBASE + rsp[8];
    return -1;
  }
  if (rsp[7] != b.function || rsp[8] != 2 * b.count || n != 9 + 2 * b.count) {
    *mismatch = fmt::format("reply function {} with {} data bytes in {}, expected function {} with {}", rsp[7],
                            rsp[8], n, b.function, 2 * b.count);
    return -1;
  }
  for (int i = 0; i < b.count; ++i) regs[i] = u16(9 + 2 * i);
  return b.count;
}

bool ModbusLink::recover_after(const DeviceSpec& d, const ReadResult& r, const std::atomic<bool>* stop) {
  if (r.status == ReadStatus::Ok || r.status == ReadStatus::Exception) return false;  // the reply answered the request
  if (settings_.transport == Transport::Rtu) {
    drain_late_reply(d, r.t_send_ns, stop);
    return false;
  }
  if (!connected_) return false;  // already closed (disconnected): reconnected at the next deadline
  close();
  return true;
}

void ModbusLink::drain_late_reply(const DeviceSpec& d, std::int64_t t_send_ns, const std::atomic<bool>* stop) {
  if (settings_.transport != Transport::Rtu || !ctx_) return;
  // The latest reply ends late_reply_ms after the request plus its own wire time. Waited
  // in slices of at most 50 ms so a stop request is seen promptly.
  const auto until = t_send_ns + static_cast<std::int64_t>((d.late_reply_ms * 1e-3 + wire_time_s(d)) * 1e9);
  for (auto now = monotonic_ns(); now < until; now = monotonic_ns()) {
    if (stop && stop->load()) return;
    std::this_thread::sleep_for(std::chrono::nanoseconds(std::min<std::int64_t>(until - now, 50'000'000)));
  }
  modbus_flush(ctx_);
}

}  // namespace burrbench::rig
