#pragma once
#include <atomic>
// One libmodbus connection (a TCP device or an RS-485 bus) with our own error recovery:
// libmodbus runs with MODBUS_ERROR_RECOVERY_NONE and the poller decides what to do.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "burrbench/rig/register_map.hpp"

typedef struct _modbus modbus_t;

namespace burrbench::rig {

std::int64_t monotonic_ns();  // CLOCK_MONOTONIC

enum class ReadStatus { Ok, Timeout, Exception, BadData, Disconnected, EarlyReply };
const char* to_string(ReadStatus s);

struct ReadResult {
  ReadStatus status = ReadStatus::Ok;
  std::int64_t t_send_ns = 0, t_recv_ns = 0;
  std::int64_t t_first_recv_ns = 0;  // reply to the poll's first request (= t_recv_ns with one block)
  // Blocks read, counting from the first one requested (see ModbusLink::read's `enough`).
  std::size_t blocks_read = 0;
  std::string detail;  // libmodbus error text when not Ok
};

class ModbusLink {
 public:
  explicit ModbusLink(const DeviceSpec& settings);  // for a bus: any device on it
  ~ModbusLink();
  ModbusLink(const ModbusLink&) = delete;
  ModbusLink& operator=(const ModbusLink&) = delete;

  // Always closes first (libmodbus 3.1.6 leaks the socket on a second connect).
  bool connect(std::string* error);
  void close();
  bool connected() const { return connected_; }
  // Reads d's blocks, one request each, into regs (resized to d.count, laid end to end);
  // t_send_ns is the first request's, t_recv_ns the last reply's. In order, except a FIFO
  // with record counters: from the last block (its newest records) to the first. The first failure ends
  // the poll (its status and detail, naming the block when there are several).
  // `enough(k)`, when given, is asked after each block k read (by its index in d.blocks):
  // true ends the poll there. The blocks not read keep what regs held; blocks_read says
  // how many were (a FIFO read newest first: the last blocks_read blocks of d.blocks).
  ReadResult read(const DeviceSpec& d, std::vector<std::uint16_t>& regs,
                  const std::function<bool(std::size_t block)>& enough = {});
  // What the transport needs after a failed read `r` of d, before the next request; the
  // callers (poller, tare) never ask which transport this is.
  //  - RTU has no transaction id: unless an exception reply answered the request, wait out
  //    the latest possible reply, then drop any bytes, so a late reply is never taken as
  //    the answer to the next request (cut short, without flushing, once *stop is set).
  //  - TCP after a timeout or bad data: the stream may be out of step, so the connection
  //    is closed. An exception reply keeps it.
  // True when this closed the connection: the caller reconnects (at once, then backing off).
  bool recover_after(const DeviceSpec& d, const ReadResult& r, const std::atomic<bool>* stop = nullptr);
  // The line d's requests travel on: devices on one line share one connection, polled by
  // one thread one request at a time — an RS-485 bus (its serial device), while a TCP
  // device has a connection of its own.
  static std::string line(const DeviceSpec& d);
  // Shortest possible request+reply time on the wire (RTU), 0 for TCP.
  double wire_time_s(const DeviceSpec& d) const;
  std::string describe() const;

 private:
  // TCP read sent raw, its reply checked here (see modbus_link.cpp); returns rc as
  // modbus_read_registers would, with errno set the same way.
  int read_tcp_checked(const DeviceSpec& d, const BlockSpec& b, std::uint16_t* regs, std::string* mismatch);
  // RTU: the wait and flush of recover_after.
  void drain_late_reply(const DeviceSpec& d, std::int64_t t_send_ns, const std::atomic<bool>* stop);
  // One request of a poll.
  ReadResult read_block(const DeviceSpec& d, const BlockSpec& b, std::uint16_t* regs);
  DeviceSpec settings_;
  modbus_t* ctx_ = nullptr;
  bool connected_ = false;
};

}  // namespace burrbench::rig
