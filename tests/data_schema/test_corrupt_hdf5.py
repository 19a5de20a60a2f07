"""HDF5 files that crash libhdf5 itself (issue 59, found by bench/fuzz/fuzz_prediction_h5).

corrupt/prediction_link_heap.h5.gz is a small prediction file (the fuzz seed writer's)
with one byte of a group's dense link storage (a fractal heap direct block) changed: Debian's
libhdf5 1.10.8 frees a pointer it never allocated while listing that group's links, and
`burrbench inspect` died with SIGSEGV (exit 139). Every reader now walks a file's structure
in a forked child first; a child that dies makes the file bad input: exit 2, one line."""
import gzip
import hashlib
import os
import subprocess
import sys
from pathlib import Path

import pytest

from bad_input import assert_refused

BURRBENCH = os.environ["BURRBENCH"]
HERE = Path(__file__).parent


@pytest.fixture
def corrupt(tmp_path):
    p = tmp_path / "prediction.h5"
    p.write_bytes(gzip.decompress((HERE / "corrupt" / "prediction_link_heap.h5.gz").read_bytes()))
    return p


def test_a_file_that_crashes_libhdf5_is_bad_input(corrupt):
    before = hashlib.sha256(corrupt.read_bytes()).hexdigest()
    r = subprocess.run([BURRBENCH, "inspect", corrupt], capture_output=True, text=True, timeout=120)
    assert r.returncode not in (-11, 139), "libhdf5's crash reached the user"
    assert_refused(r.returncode, r.stderr, corrupt, "corrupt", label="libhdf5 crash")
    assert hashlib.sha256(corrupt.read_bytes()).hexdigest() == before


@pytest.mark.parametrize("name_length", [1, 40, 120])
def test_the_python_module_refuses_it_too(corrupt, name_length):
    # The module's readers are the C++ readers: the same refusal, as an exception. Whether
    # libhdf5's bad free aborts depends on the heap it runs in, and a longer path changes
    # the heap: one length once passed where another crashed the interpreter.
    corrupt = corrupt.rename(corrupt.with_name("p" * name_length + ".h5"))
    build = os.environ.get("BURRBENCH_BUILD_DIR")
    if not build or not (Path(build) / "python" / "burrbench").is_dir():
        pytest.skip("no Python module in this build")
    code = ("import burrbench, sys\ntry:\n    burrbench.validate('prediction', sys.argv[1])\n"
            "except Exception as e:\n    print(type(e).__name__, e)\n    sys.exit(3)\n")
    r = subprocess.run([sys.executable, "-c", code, str(corrupt)], capture_output=True, text=True, timeout=120,
                       env={**os.environ, "PYTHONPATH": str(Path(build) / "python")})
    assert r.returncode == 3 and "corrupt" in r.stdout, (r.returncode, r.stdout, r.stderr[-500:])
