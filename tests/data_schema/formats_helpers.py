"""Shared helpers for the h5py format tests: run the CLI, write fixtures, copy files."""
import os
import shutil
import subprocess
from pathlib import Path

from bad_input import assert_refused

BURRBENCH = os.environ.get("BURRBENCH", "burrbench")


def run(*args, timeout=60):
    """Runs the burrbench CLI; returns (exit code, stdout, stderr)."""
    p = subprocess.run([BURRBENCH, *map(str, args)], capture_output=True, text=True, errors="replace", timeout=timeout)
    return p.returncode, p.stdout, p.stderr


def write_fixtures(folder: Path) -> Path:
    rc, out, err = run("debug", "write-fixtures", folder)
    assert rc == 0, err
    return folder


def copy(src: Path, dst: Path) -> Path:
    shutil.copyfile(src, dst)
    return dst


def assert_rejected(path: Path, *fragments):
    """`inspect` must exit 2 with one stderr line holding every fragment and leave the bytes alone."""
    before = path.read_bytes()
    rc, out, err = run("inspect", path)
    assert_refused(rc, err, path, *fragments)
    assert path.read_bytes() == before, "input file was modified"
    return err
