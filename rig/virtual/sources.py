"""What the virtual devices measure: a deterministic pattern or a played recording.

A source answers, for each device ("ft", "stage", "spindle"), two questions:
index(device, t_s) -> the device sample counter at t_s seconds after the start of
playback (the newest sample whose time <= t_s), and value(device, k) -> the
sample with counter k (a 6-tuple wrench for "ft", (x, y, z) mm for "stage",
signed rpm for "spindle"). The register images are built from these.
"""
import math

DEVICES = ("ft", "stage", "spindle")

# Patterns: j = k mod RAMP_PERIOD keeps every int16 register in range forever.
RAMP_PERIOD = 10000

CONSTANTS = {
    "ft": (1.5, -2.25, 100.0, 250.0, -500.0, 1000.0),
    "stage": (12.345, -6.789, 100.0),
    "spindle": -30000.0,
}

SATURATE = {
    "ft": (400.0, -400.0, 0.5, 40000.0, -40000.0, 0.0),
    "stage": (3.0e6, -3.0e6, 0.0),  # beyond int32 micrometres
    "spindle": 70000.0,             # beyond uint16
}


def ramp_value(device, k):
    """The documented `ramp` pattern (README.md): exact in int16 registers."""
    j = k % RAMP_PERIOD
    if device == "ft":
        return (0.01 * j, -0.02 * j, 0.03 * j, 1.0 * j, -2.0 * j, 3.0 * j)
    if device == "stage":
        return (0.001 * k, -0.002 * k, 0.003 * k)
    sign = -1.0 if (k // RAMP_PERIOD) % 2 else 1.0
    return sign * (j + 1)


class PatternSource:
    """Each device samples at its rate (rate_hz unless overridden) from the start of playback."""

    def __init__(self, name, rate_hz, device_rates=None):
        if name not in PATTERNS:
            raise ValueError(f"--pattern: expected one of {', '.join(PATTERNS)}, got {name!r}")
        self.name = name
        self.rates = {d: rate_hz for d in DEVICES}
        self.rates.update({d: r for d, r in (device_rates or {}).items() if r})
        self._fn = PATTERNS[name]

    def devices(self):
        return DEVICES

    def index(self, device, t_s):
        return max(0, int(math.floor(t_s * self.rates[device])))

    def value(self, device, k):
        return self._fn(device, k)

    def spindle_load(self, k):
        """The drive's load torque (N·mm): a sawtooth 0, 0.05, ... 4.95 with "ramp", else 0."""
        return 0.05 * (k % 100) if self.name == "ramp" else 0.0


NONFINITE = {
    "ft": (math.nan, math.inf, -math.inf, math.nan, 0.0, 0.0),
    "stage": (math.nan, math.inf, -math.inf),
    "spindle": math.nan,
}

PATTERNS = {
    "ramp": ramp_value,
    "constants": lambda device, k: CONSTANTS[device],
    "saturate": lambda device, k: SATURATE[device],
    "nonfinite": lambda device, k: NONFINITE[device],
}


# Refused before reading: 10 M samples is 2.8 h at 1 kHz (0.5 GB as n×6 doubles).
MAX_SAMPLES = 10_000_000


class RecordingError(Exception):
    """A recording that cannot be played (message names file and field)."""


class RecordingSource:
    """Plays a burrbench recording (docs/formats.md) in real time.

    Each device serves the stream holding its canonical channel: ft <- force_N
    (+ torque_Nmm from the same stream if present, else zero), stage <-
    position_mm, spindle <- spindle_rpm (+ spindle_torque_Nmm from the same stream
    if present, else zero: the drive's load register). Times are relative to the earliest
    sample of any stream, so the lags between streams are kept. Before a
    stream's first sample that first sample is served; after the last one the
    last sample is held (counter stops) unless loop is set, in which case the
    whole recording repeats and counters keep counting up. Samples flagged stale
    by the acquisition are skipped; of samples with equal t_ns the last is shown.
    """

    def __init__(self, path, loop=False):
        try:
            self._load(path, loop)
        except RecordingError:
            raise
        except (KeyError, ValueError, TypeError, AttributeError, OSError) as exc:
            # Layouts no check above foresaw (a dataset where a group belongs, ...).
            raise RecordingError(f"{path}: /streams: expected the burrbench recording layout, got {exc}")

    def _load(self, path, loop):
        import h5py
        import numpy as np

        self.path = str(path)
        self.loop = loop
        self._np = np
        self._t = {}     # device -> int64 ns relative to start
        self._vals = {}  # device -> ndarray n x width
        try:
            f = h5py.File(self.path, "r")
        except OSError as exc:
            raise RecordingError(f"{self.path}: file: expected an HDF5 recording, got {exc}")
        with f:
            fmt = f.attrs.get("format")
            if isinstance(fmt, bytes):
                fmt = fmt.decode(errors="replace")
            if fmt is not None and fmt != "burrbench.recording":
                raise RecordingError(f"{self.path}: /@format: expected burrbench.recording, got {fmt}")
            streams = f.get("streams")
            if streams is None or not hasattr(streams, "keys"):
                raise RecordingError(f"{self.path}: /streams: expected a group of streams, got none")
            found = {}
            for sname in streams.keys():
                grp = streams[sname]
                chans = grp.get("channels")
                if chans is None:
                    continue
                for dev, ch in (("ft", "force_N"), ("stage", "position_mm"), ("spindle", "spindle_rpm")):
                    if ch in chans and dev not in found:
                        found[dev] = (sname, grp)
            if not found:
                raise RecordingError(
                    f"{self.path}: /streams/*/channels: expected force_N, position_mm or spindle_rpm, got none")
            raw_t = {}
            for dev, (sname, grp) in found.items():
                where = f"{self.path}: /streams/{sname}"
                if "t_ns" not in grp:
                    raise RecordingError(f"{where}/t_ns: expected int64 timestamps, got none")
                if grp["t_ns"].ndim != 1 or grp["t_ns"].shape[0] > MAX_SAMPLES:
                    raise RecordingError(f"{where}/t_ns: expected a 1-D dataset of at most "
                                         f"{MAX_SAMPLES} samples, got shape {grp['t_ns'].shape}")
                try:
                    t = np.asarray(grp["t_ns"][...], dtype=np.int64).reshape(-1)
                except (ValueError, TypeError):
                    raise RecordingError(f"{where}/t_ns: expected int64 values, got {grp['t_ns'].dtype}")
                n = t.size
                if n == 0:
                    raise RecordingError(f"{where}/t_ns: expected at least one sample, got 0")
                if n > 1 and np.any(np.diff(t) < 0):
                    raise RecordingError(f"{where}/t_ns: expected non-decreasing, got a step back")
                chans = grp["channels"]
                # Samples an acquisition marked stale repeat an older value: the device
                # produced nothing new then, so they are not played as device samples.
                fresh = np.ones(n, dtype=bool)
                if "stale" in grp:
                    st = np.asarray(grp["stale"][...]).reshape(-1)
                    if st.size != n:
                        raise RecordingError(f"{where}/stale: expected {n} values, got {st.size}")
                    fresh = st == 0
                    if not fresh.any():
                        raise RecordingError(f"{where}/stale: expected at least one fresh sample, got none")
                if dev == "ft":
                    v = self._channel(chans, "force_N", n, 3, where)
                    tq = (self._channel(chans, "torque_Nmm", n, 3, where) if "torque_Nmm" in chans
                          else np.zeros((n, 3)))
                    v = np.hstack([v, tq])
                elif dev == "stage":
                    v = self._channel(chans, "position_mm", n, 3, where)
                else:
                    v = self._channel(chans, "spindle_rpm", n, 1, where)
                    load = (self._channel(chans, "spindle_torque_Nmm", n, 1, where) if "spindle_torque_Nmm" in chans
                            else np.zeros((n, 1)))
                    v = np.hstack([v, load])
                raw_t[dev] = t[fresh]
                self._vals[dev] = v[fresh]
        t0 = min(int(t[0]) for t in raw_t.values())
        for dev, t in raw_t.items():
            self._t[dev] = t - t0
        # One loop lasts until the last sample of any stream plus one median period.
        ends = []
        for t in self._t.values():
            period = max(1, int(np.median(np.diff(t)))) if t.size > 1 else 1_000_000
            ends.append(int(t[-1]) + period)
        self.duration_ns = max(ends)

    def _channel(self, chans, name, n, width, where):
        np = self._np
        ds = chans[name]
        if ds.shape not in ((n, width), (n,) if width == 1 else None):
            raise RecordingError(
                f"{where}/channels/{name}: expected shape ({n}, {width}), got {ds.shape}")
        try:
            a = np.asarray(ds[...], dtype=np.float64)
        except (ValueError, TypeError):
            raise RecordingError(f"{where}/channels/{name}: expected float64 values, got {ds.dtype}")
        if a.ndim == 1 and width == 1:
            a = a.reshape(-1, 1)
        if a.ndim != 2 or a.shape != (n, width):
            raise RecordingError(
                f"{where}/channels/{name}: expected shape ({n}, {width}), got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise RecordingError(f"{where}/channels/{name}: expected finite values, got NaN/Inf")
        return a

    def devices(self):
        return tuple(d for d in DEVICES if d in self._t)

    def index(self, device, t_s):
        t = self._t[device]
        n = t.size
        now = int(t_s * 1e9)
        lap = 0
        if self.loop:
            lap, now = divmod(now, self.duration_ns)
        i = int(self._np.searchsorted(t, now, side="right")) - 1
        return lap * n + max(0, i)

    def value(self, device, k):
        v = self._vals[device]
        i = k % v.shape[0] if self.loop else min(k, v.shape[0] - 1)
        row = v[i]
        if device == "spindle":
            return float(row[0])
        return tuple(float(x) for x in row)

    def spindle_load(self, k):
        """The spindle drive's load torque (N·mm) of spindle sample k."""
        v = self._vals["spindle"]
        i = k % v.shape[0] if self.loop else min(k, v.shape[0] - 1)
        return float(v[i][1])
