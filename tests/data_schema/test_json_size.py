"""Issue 59, D11: a 100 MB fit.json made `inspect` take 2.6 GB and 74 s (SIGABRT under a
2 GB limit). A JSON input's size is checked before it is read: at most 32 MiB, refused as
bad input (exit 2, one line naming the file) at once."""
import os
import subprocess
import time

from bad_input import assert_refused

BURRBENCH = os.environ["BURRBENCH"]


def big_fit(path, mib=40):
    n = (mib << 20) // 2
    with open(path, "w") as f:
        f.write('{"format": "burrbench.fit", "format_version": "1.0", "x": [')
        f.write("0," * n)
        f.write("0]}\n")


def test_a_json_input_beyond_32_mib_is_refused_before_it_is_read(tmp_path):
    fit = tmp_path / "fit.json"
    big_fit(fit)
    t0 = time.monotonic()
    p = subprocess.run([BURRBENCH, "inspect", str(fit)], capture_output=True, text=True, timeout=300)
    assert_refused(p.returncode, p.stderr, fit, "<file>: expected a JSON file of at most 32 MiB")
    assert time.monotonic() - t0 < 10, time.monotonic() - t0
