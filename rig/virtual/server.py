"""Modbus TCP / RTU serving with deterministic fault injection (pymodbus 3.0).

We run our own asyncio loop and close the pymodbus servers ourselves, which avoids
ServerStop()'s 10 s sleep. Faults are applied per connection (one RTU port = one
connection) and counted in requests that reached a known unit id, 1-based.
"""
import asyncio
import sys
import time

from pymodbus.datastore import ModbusServerContext
from pymodbus.framer.rtu_framer import ModbusRtuFramer
from pymodbus.framer.socket_framer import ModbusSocketFramer
from pymodbus.pdu import ModbusExceptions as merror
from pymodbus.server.async_io import (ModbusConnectedRequestHandler, ModbusSerialServer,
                                      ModbusSingleRequestHandler, ModbusTcpServer)

from devices import READ_HOLDING


class Faults:
    """Fault-injection settings (all off by default)."""

    def __init__(self, delay_ms=0.0, late_every=0, late_ms=0.0, exception_every=0,
                 drop_every_s=0.0, restart_at_s=0.0, restart_down_s=0.0, restart_reset=False,
                 busy_at_s=0.0, busy_for_s=0.0, wrong_unit_every=0, late_sample_every=0, late_sample_ms=0.0):
        self.delay_ms = delay_ms
        self.late_every = late_every
        self.late_ms = late_ms
        self.exception_every = exception_every
        self.drop_every_s = drop_every_s
        self.restart_at_s = restart_at_s
        self.restart_down_s = restart_down_s
        self.restart_reset = restart_reset
        self.wrong_unit_every = wrong_unit_every
        self.late_sample_every = late_sample_every
        self.late_sample_ms = late_sample_ms
        self.busy_at_s = busy_at_s
        self.busy_for_s = busy_for_s
        self.start_ns = time.monotonic_ns()  # reset when READY is announced
        self.silent = False  # set while an RTU device is "restarting"

    def busy(self):
        """Inside the --busy-at-s window: every read is answered SLAVE_DEVICE_BUSY."""
        t = (time.monotonic_ns() - self.start_ns) * 1e-9
        return self.busy_for_s > 0 and self.busy_at_s <= t < self.busy_at_s + self.busy_for_s


class ServedLog:
    """--served-log: one CSV line per read reply actually written to the client.

    `t_mono_ns,unit,address,count,counter`: the CLOCK_MONOTONIC time of the write and
    the device counter of the sample the reply carries. Replies that were never sent
    (connection dropped before a late reply, a silent restart) are not listed, so a
    test can check that every sample the rig delivered reached the recording.
    """

    def __init__(self, path, playback):
        self.playback = playback
        self.f = open(path, "w", buffering=1 << 16)
        self.f.write("t_mono_ns,unit,address,count,counter\n")

    def take(self):
        """The read just executed (or None for an exception reply)."""
        info, self.playback.last_read = self.playback.last_read, None
        return info

    def written(self, info):
        if info is not None:
            self.f.write(f"{time.monotonic_ns()},{info[0]},{info[1]},{info[2]},{info[3]}\n")

    def flush(self):
        self.f.flush()

    def close(self):
        self.f.close()


def log_event(kind, **kw):
    """One line per injected fault on stderr, for people and tests."""
    detail = " ".join(f"{k}={v}" for k, v in kw.items())
    print(f"EVENT {kind} t_mono_ns={time.monotonic_ns()} {detail}".rstrip(), file=sys.stderr,
          flush=True)


class FaultMixin:
    """Refuses everything but reads, injects exceptions and delays, keeps replies in order."""

    faults = Faults()
    served_log = None

    def _fault_init(self):
        if not hasattr(self, "_n_requests"):
            self._n_requests = 0
            self._send_after = 0.0  # loop time of the previous reply: replies stay in order
            self._delay_s = 0.0

    def execute(self, request, *addr):
        self._fault_init()
        self._n_requests += 1
        n = self._n_requests
        f = self.faults
        delay = f.delay_ms * 1e-3
        if f.late_every and n % f.late_every == 0:
            delay += f.late_ms * 1e-3
        self._delay_s = delay
        self._wrong_unit = bool(f.wrong_unit_every and n % f.wrong_unit_every == 0)
        if f.silent:
            return  # a rebooting device on the bus does not answer
        if self.served_log is not None:
            self.served_log.take()  # forget any read not answered
        if request.function_code != READ_HOLDING:
            # The rig is read-only: a write (or any other function) is refused.
            self._reply(request, request.doException(merror.IllegalFunction), addr)
        elif (f.exception_every and n % f.exception_every == 0) or f.busy():
            self._reply(request, request.doException(merror.SlaveBusy), addr)
        elif f.late_sample_every and n % f.late_sample_every == 0:
            # A device slow to answer: it reads its registers (and replies) late_sample_ms
            # after the request came, so the sample carried is a late one.
            execute = super().execute
            asyncio.get_running_loop().call_later(f.late_sample_ms * 1e-3, lambda: execute(request, *addr))
        else:
            super().execute(request, *addr)

    def _reply(self, request, response, addr):
        response.transaction_id = request.transaction_id
        response.unit_id = request.unit_id
        self.send(response, *addr)

    def send(self, message, *addr, **kwargs):
        self._fault_init()
        info = self.served_log.take() if self.served_log is not None else None
        if getattr(self, "_wrong_unit", False):
            # A reply under another unit id (a gateway mixing up its devices): not a reply
            # of the device asked, so not in the served log.
            message.unit_id = (message.unit_id + 1) % 256
            info = None
        loop = asyncio.get_running_loop()
        now = loop.time()
        if self._delay_s <= 0 and self._send_after <= now:
            self._send_now(message, addr, kwargs, info)
            return
        at = max(now + self._delay_s, self._send_after)
        self._send_after = at
        loop.call_at(at, self._send_now, message, addr, kwargs, info)

    def _send_now(self, message, addr, kwargs, info):
        transport = getattr(self, "transport", None)
        if transport is None or transport.is_closing():
            return
        super().send(message, *addr, **kwargs)
        if self.served_log is not None:
            self.served_log.written(info)


class _DirectMixin:
    """Frame and answer requests right in data_received.

    pymodbus 3.0 queues every chunk and wakes a per-connection task to parse it;
    doing it inline halves the server's cost per request (measured in README.md).
    """

    def data_received(self, data):
        try:
            self.framer.processIncomingPacket(
                data=data, callback=self.execute, unit=self._units, single=False)
        except Exception:  # pylint: disable=broad-except
            # Same policy as pymodbus' handler: garbage on a stream ends the connection.
            self.framer.resetFrame()
            if self._closes_on_error:
                self.transport.close()

    @property
    def _units(self):
        return list(self.server.context.slaves())


class TcpHandler(FaultMixin, _DirectMixin, ModbusConnectedRequestHandler):
    _closes_on_error = True


class RtuHandler(FaultMixin, _DirectMixin, ModbusSingleRequestHandler):
    _closes_on_error = False


def _server_context(contexts):
    return ModbusServerContext(slaves=contexts, single=False)


class TcpRig:
    """Listens on host:port; drop and restart act on the pymodbus server underneath."""

    def __init__(self, contexts, host, port, faults):
        self.contexts = contexts
        self.host = host
        self.port = port
        self.faults = faults
        TcpHandler.faults = faults
        self.server = None
        self._task = None

    async def start(self):
        self.server = ModbusTcpServer(
            _server_context(self.contexts), framer=ModbusSocketFramer,
            address=(self.host, self.port), handler=TcpHandler, allow_reuse_address=True,
            ignore_missing_slaves=True, backlog=64)
        self._task = asyncio.create_task(self.server.serve_forever())
        serving = asyncio.ensure_future(self.server.serving)
        done, _ = await asyncio.wait({serving, self._task}, return_when=asyncio.FIRST_COMPLETED)
        if serving not in done:
            self._task.result()  # raises the bind error
            raise RuntimeError("server stopped before listening")
        self.port = self.server.server.sockets[0].getsockname()[1]

    async def go_down(self):
        await self.stop()

    async def come_up(self):
        await self.start()

    def drop_connections(self):
        n = 0
        for handler in list(self.server.active_connections.values()) if self.server else []:
            handler.transport.abort()
            n += 1
        return n

    async def stop(self):
        if self.server is None:
            return
        self.drop_connections()
        server, self.server = self.server, None
        if server.server is not None:
            server.server.close()
        if self._task is not None:
            self._task.cancel()
            try:
                await self._task
            except (asyncio.CancelledError, Exception):  # pylint: disable=broad-except
                pass
        self._task = None


class RtuRig:
    """pymodbus serial server (RTU framer, not the ASCII default) on a pty."""

    def __init__(self, contexts, device, baud, faults):
        RtuHandler.faults = faults
        self.server = ModbusSerialServer(
            _server_context(contexts), framer=ModbusRtuFramer, port=device, baudrate=baud,
            handler=RtuHandler, ignore_missing_slaves=True)
        self.faults = faults

    async def start(self):
        await self.server.start()
        if self.server.transport is None:
            raise RuntimeError(f"cannot open {self.server.device}")

    def drop_connections(self):
        return 0  # a serial line has no connection to drop

    async def go_down(self):
        self.faults.silent = True

    async def come_up(self):
        self.faults.silent = False

    async def stop(self):
        await self.server.shutdown()


async def run_fault_schedule(rig, playback, faults):
    """Periodic drops and the one restart, on a fixed schedule from the start."""
    t0 = asyncio.get_running_loop().time()
    tasks = []

    async def dropper():
        k = 1
        while True:
            await asyncio.sleep(max(0.0, t0 + k * faults.drop_every_s - asyncio.get_running_loop().time()))
            n = rig.drop_connections()
            log_event("drop", index=k, connections=n)
            k += 1

    async def restarter():
        await asyncio.sleep(max(0.0, t0 + faults.restart_at_s - asyncio.get_running_loop().time()))
        log_event("restart-down", down_s=faults.restart_down_s)
        await rig.go_down()
        await asyncio.sleep(faults.restart_down_s)
        if faults.restart_reset:
            playback.reset_counters()
        await rig.come_up()
        log_event("restart-up", counter_reset=int(faults.restart_reset))

    if faults.drop_every_s > 0:
        tasks.append(asyncio.create_task(dropper()))
    if faults.restart_at_s > 0:
        tasks.append(asyncio.create_task(restarter()))
    return tasks
