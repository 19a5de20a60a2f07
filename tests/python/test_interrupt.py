"""Stopping long work from Python (python/src/interruptible.hpp, docs/python.md): Ctrl-C (a
notebook's interrupt button sends the same SIGINT) raises KeyboardInterrupt within a
moment, not when the calibration or replay would have ended; a progress callback that
raises stops the calibration too. The module keeps working afterwards."""
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from synthetic import make_synthetic

BUILD_PY = str(Path(os.environ["BURRBENCH_BUILD_DIR"]) / "python")
sys.path.insert(0, BUILD_PY)
import burrbench  # noqa: E402

# A child that runs `work` as a user at a terminal would; it prints "started", then how it
# ended (with time.monotonic(), comparable across processes), then replays once more.
CHILD = r"""
import signal, sys, time
sys.path.insert(0, sys.argv[1])
import burrbench
# As at a terminal: a child of a background job may start with SIGINT ignored.
signal.signal(signal.SIGINT, signal.default_int_handler)
exp, params, what = sys.argv[2], sys.argv[3], sys.argv[4]
def progress(fraction, line):
    print("progress", line, flush=True)
print("started", flush=True)
try:
    if what == "calibrate":
        burrbench.calibrate(exp, progress=progress)
    else:
        burrbench.replay(exp, params, step_us=2.0)
    print("finished", flush=True)
except KeyboardInterrupt:
    print(f"interrupted {time.monotonic():.6f}", flush=True)
pred = burrbench.replay(exp, params)
print("replayed", " ".join(sorted(pred)), flush=True)
"""


@pytest.fixture(scope="module")
def exp(tmp_path_factory):
    return make_synthetic(tmp_path_factory.mktemp("interrupt"))


def interrupt(exp, what, wait_for):
    p = subprocess.Popen([sys.executable, "-c", CHILD, BUILD_PY, str(exp / "experiment.toml"),
                          str(exp / "params_true.toml"), what],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    seen = []
    for line in p.stdout:
        seen.append(line)
        if wait_for(line):
            break
    else:
        p.wait(timeout=60)
        pytest.fail("the child ended before the signal: " + "".join(seen) + p.stderr.read())
    sent = time.monotonic()
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=120)
    assert p.returncode == 0, out + err
    ended = [line for line in out.splitlines() if line.startswith(("interrupted", "finished"))]
    assert ended and ended[0].startswith("interrupted"), out + err
    assert "replayed plunge polish sweep" in out, out + err  # the module works on
    return float(ended[0].split()[1]) - sent


def test_ctrl_c_stops_a_calibration(exp):
    # Signalled once the global search's local solves replay (≈ 0.7 s into ≈ 3 s of
    # calibration here); it stops within one replay chunk, ≈ 0.1 s.
    after = interrupt(exp, "calibrate", lambda line: "local solve" in line)
    print(f"KeyboardInterrupt {after:.3f} s after the signal")
    assert after < 2.0, after


def test_ctrl_c_stops_a_replay(exp):
    # A replay at a 2 µs step takes ≈ 7 s here; signalled half a second in.
    def half_a_second_in(line):
        if line.startswith("started"):
            time.sleep(0.5)
            return True
        return False
    after = interrupt(exp, "replay", half_a_second_in)
    print(f"KeyboardInterrupt {after:.3f} s after the signal")
    assert after < 2.0, after


def test_a_raising_progress_callback_stops_the_calibration(exp):
    raised = {}

    def progress(fraction, line):
        if "local solve" in line:
            raised["at"] = time.monotonic()
            raise ValueError("enough")
    with pytest.raises(ValueError, match="enough"):
        burrbench.calibrate(exp / "experiment.toml", progress=progress)
    stopped = time.monotonic() - raised["at"]
    print(f"ValueError {stopped:.3f} s after the callback raised")
    # Before, the calibration ran on to its end (≈ 2.5 s more here) and raised then.
    assert stopped < 1.0, stopped
    # A calibration after it runs whole.
    out = burrbench.calibrate(exp / "experiment.toml", starts=2, profiles=False, cross_validate=False,
                              discretization_check=False)
    assert out["params"]["compact"]["mu"] == pytest.approx(0.4, rel=0.05)


def test_a_raising_progress_callback_stops_a_replay(exp):
    # A replay at a 2 µs step takes ≈ 7 s here; the callback raises at its first line past
    # 5 % of the experiment.
    raised = {}

    def progress(fraction, line):
        if fraction is not None and fraction > 0.05 and "at" not in raised:
            raised["at"] = time.monotonic()
            raise ValueError("enough")
    with pytest.raises(ValueError, match="enough"):
        burrbench.replay(exp / "experiment.toml", exp / "params_true.toml", step_us=2.0, progress=progress)
    stopped = time.monotonic() - raised["at"]
    print(f"ValueError {stopped:.3f} s after the callback raised")
    assert stopped < 1.0, stopped
    pred = burrbench.replay(exp / "experiment.toml", exp / "params_true.toml")
    assert sorted(pred) == ["plunge", "polish", "sweep"]
