"""pymodbus datastore for the three virtual devices.

The register values are computed from the source at the moment of the read (the
device counter is a function of time), so no background task is needed and a
multi-register read is always one consistent sample. Images are cached per
sample index: at 1 kHz polling most reads hit the cache.
"""
import time

from pymodbus.interfaces import IModbusSlaveContext

import registers as R

READ_HOLDING = 3

_UNITS = {"ft": (R.FT_UNIT, R.FT_SIZE), "stage": (R.STAGE_UNIT, R.STAGE_SIZE),
          "spindle": (R.SPINDLE_UNIT, R.SPINDLE_SIZE)}


class Playback:
    """Shared clock and register images of every device."""

    def __init__(self, source, counter_start=0, status_every=0, ft_fifo_depth=0, stage_fifo_depth=0,
                 spindle_rated_Nmm=10.0):
        self.source = source
        self.spindle_rated_Nmm = spindle_rated_Nmm  # full scale of the load register (1000 = 100 %)
        # the deep FIFOs' records (0: off)
        self.deep_depth = {"ft": ft_fifo_depth, "stage": stage_fifo_depth}
        self.status_every = status_every  # ft sample k with k % N == 0 sets the overload bit
        self.start_ns = time.monotonic_ns()
        # Subtracted from the sample index: -counter_start at first, the index of the
        # restart after a reset.
        self.counter_base = {d: -counter_start for d in source.devices()}
        self._cache = {}
        # (unit, address, count, counter) of the latest read; the server notes it
        # with the reply for --served-log.
        self.last_read = None

    def restart_clock(self):
        """Sample 0 is now (CLOCK_MONOTONIC, the same clock as the host's pollers)."""
        self.start_ns = time.monotonic_ns()
        self._cache.clear()

    def t_s(self):
        return (time.monotonic_ns() - self.start_ns) * 1e-9

    def reset_counters(self):
        """A device reboot: counters restart at 0 from the current sample."""
        t = self.t_s()
        for d in self.counter_base:
            self.counter_base[d] = self.source.index(d, t)
        self._cache.clear()

    def image(self, device):
        """(counter, registers) of the device's current sample."""
        k = self.source.index(device, self.t_s())
        hit = self._cache.get(device)
        if hit is not None and hit[0] == k:
            return k - self.counter_base[device], hit[1]
        regs = self._build(device, k)
        self._cache[device] = (k, regs)
        return k - self.counter_base[device], regs

    def _build(self, device, k):
        src = self.source
        counter = k - self.counter_base[device]
        if device == "ft":
            overload = bool(self.status_every) and k % self.status_every == 0
            return R.ft_image(counter, src.value("ft", k), self._fifo(device, k, R.FIFO_DEPTH), overload,
                              self._deep(device, k))
        if device == "stage":
            return R.stage_image(counter, src.value("stage", k), self._fifo(device, k, R.STAGE_FIFO_DEPTH),
                                 self._deep(device, k))
        return R.spindle_image(counter, src.value("spindle", k), src.spindle_load(k), self.spindle_rated_Nmm)


    def _deep(self, device, k):
        """The deep FIFO's (counter, value) records, oldest first; () when it is off."""
        depth = self.deep_depth.get(device, 0)
        if not depth:
            return ()
        base = self.counter_base[device]
        return [(i - base, v) if v is not None else None
                for i, v in zip(range(k - depth + 1, k + 1), self._fifo(device, k, depth))]

    def _fifo(self, device, k, depth):
        """Samples k-depth+1..k, oldest first; None before sample 0 or the last reset."""
        base = self.counter_base[device]
        return [self.source.value(device, i) if i >= 0 and i - base >= 0 else None
                for i in range(k - depth + 1, k + 1)]


class DeviceContext(IModbusSlaveContext):
    """One unit id: read-only holding registers 0..size-1, zero-based addresses.

    Addressing is zero-based by construction (the equivalent of pymodbus'
    zero_mode=True: register 180 is protocol address 180). Only function 3 is
    valid here; writes are refused earlier with ILLEGAL_FUNCTION (server.py).
    """

    def __init__(self, playback, device):
        self.playback = playback
        self.device = device
        self.unit, self.size = _UNITS[device]
        if device == "ft":
            self.size = R.ft_size(playback.deep_depth["ft"])
        elif device == "stage":
            self.size = R.stage_size(playback.deep_depth["stage"])

    def __str__(self):
        return f"virtual {self.device} (unit {self.unit})"

    def reset(self):
        pass

    def validate(self, fc_as_hex, address, count=1):
        return fc_as_hex == READ_HOLDING and address >= 0 and address + count <= self.size

    def getValues(self, fc_as_hex, address, count=1):
        counter, regs = self.playback.image(self.device)
        self.playback.last_read = (self.unit, address, count, counter)
        return regs[address:address + count]

    def setValues(self, fc_as_hex, address, values):
        raise PermissionError("the virtual rig is read-only")


def make_contexts(playback):
    """unit id -> context, for every device the source provides."""
    return {_UNITS[d][0]: DeviceContext(playback, d) for d in playback.source.devices()}
