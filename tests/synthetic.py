"""The shipped synthetic experiment (examples/experiments/synthetic/make.sh) in a fresh
folder, and the CLI runner the tests that use it share."""
import os
import subprocess
from pathlib import Path

BURRBENCH = os.environ["BURRBENCH"]
SRC = Path(os.environ["BURRBENCH_SOURCE_DIR"])


def make_synthetic(folder):
    """Writes the synthetic experiment into `folder` (created) and returns it."""
    subprocess.run(["sh", str(SRC / "examples/experiments/synthetic/make.sh"), BURRBENCH, str(folder)],
                   check=True, capture_output=True, timeout=300)
    return Path(folder)


def run_ok(*args, timeout=900):
    """`burrbench ARGS`, which must succeed; its stdout."""
    p = subprocess.run([BURRBENCH, *map(str, args)], capture_output=True, text=True, timeout=timeout)
    assert p.returncode == 0, p.stdout + p.stderr
    return p.stdout
