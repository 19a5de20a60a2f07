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


def drill_plunge_twice(exp, folder):
    """A copy of the synthetic experiment `exp` in `folder` whose plunge was drilled twice:
    plunge.h5 copied to plunge_again.h5 and listed as a recording of its own (a second
    drilling of the same spot), and plunge.h5 listed once more as plunge_listed_again with
    role "validate" (one drilling, once per role: not a pair). Returns the new manifest."""
    import shutil
    folder = Path(folder)
    shutil.copytree(exp, folder)
    shutil.copy(folder / "plunge.h5", folder / "plunge_again.h5")
    manifest = folder / "experiment.toml"
    m = manifest.read_text()
    first = m.index("[[recordings]]")
    block = m[first:m.index("[[recordings]]", first + 1)]
    m += "\n" + block.replace('id = "plunge"', 'id = "plunge_again"').replace('"plunge.h5"', '"plunge_again.h5"')
    assert 'role = "calibrate"' in block
    m += "\n" + block.replace('id = "plunge"', 'id = "plunge_listed_again"').replace('role = "calibrate"',
                                                                                    'role = "validate"')
    manifest.write_text(m)
    return manifest


# The one warning drill_plunge_twice's experiment gives, as it begins.
PLUNGE_TWICE_WARNING = "Recordings plunge and plunge_again removed the same bone of sample S1: "
