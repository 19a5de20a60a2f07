"""A file replaced while a command reads and replays it: the outputs would record a
SHA-256 of a file the results did not come from, so the command writes nothing and names
the file (data_schema::check_unchanged; docs/formats.md "Provenance"). And `validate --fit`
replays the files the fit was made from, or refuses."""
import hashlib
import os
import shutil
import subprocess
from pathlib import Path

import pytest
from bad_input import assert_refused
from synthetic import BURRBENCH, SRC, make_synthetic, run_ok


def sha(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def exp(tmp_path_factory):
    return make_synthetic(tmp_path_factory.mktemp("synthetic") / "exp")


def test_a_sample_replaced_while_calibrate_runs_leaves_no_output(exp, tmp_path):
    folder = tmp_path / "exp"
    shutil.copytree(exp, folder)
    other = tmp_path / "other.h5"  # another scan of the same block, as a re-import would give
    run_ok("sample", "synth", "--extent-mm", 8, 8, 3, "--voxel-mm", 0.1, "--compact-mm", 1.2, "--seed", 5,
           "--out", other)
    read = sha(folder / "sample.h5")
    p = subprocess.Popen([BURRBENCH, "calibrate", folder / "experiment.toml", "--out", tmp_path / "cal", "--starts", "2",
                          "--no-profiles", "--no-cross-validation"], stderr=subprocess.PIPE, text=True)
    lines = []
    for line in p.stderr:  # the experiment is read before the global search begins
        lines.append(line.rstrip("\n"))
        if line.startswith("calibrate: global search"):
            os.replace(other, folder / "sample.h5")
            break
    lines += p.stderr.read().splitlines()
    assert p.wait(timeout=600) == 2, "\n".join(lines)
    assert lines[-1] == (f"burrbench: {folder / 'sample.h5'}: file: expected unchanged while calibrate ran (SHA-256 "
                         f"{read[:12]}… when read): its results would not describe the file on disk; nothing was "
                         f"written, run it again, got changed (now {sha(folder / 'sample.h5')[:12]}…)"), lines[-1]
    assert not (tmp_path / "cal").exists() and not list(tmp_path.glob(".cal*"))


def test_validate_with_a_fit_replays_the_files_of_the_fit(exp, tmp_path):
    folder = tmp_path / "exp"
    shutil.copytree(exp, folder)
    cal = tmp_path / "cal"
    run_ok("calibrate", folder / "experiment.toml", "--out", cal, "--starts", 2, "--no-profiles",
           "--no-cross-validation", "--no-discretization-check")
    validate = [BURRBENCH, "validate", folder / "experiment.toml", "--params", cal / "params.toml",
                "--fit", cal / "fit.json", "--criteria", SRC / "examples" / "criteria" / "release.toml",
                "--no-verification"]
    p = subprocess.run([*validate, "--out", tmp_path / "val"], capture_output=True, text=True, timeout=600)
    assert p.returncode in (0, 1) and (tmp_path / "val" / "prediction.h5").exists(), p.stderr  # 1: the gate failed
    # The held-out recording exported again since, with other data: its validation would
    # not be the fit's.
    fit_sha = sha(folder / "polish.h5")
    shutil.copy(folder / "sweep.h5", folder / "polish.h5")
    p = subprocess.run([*validate, "--out", tmp_path / "val2"], capture_output=True, text=True, timeout=600)
    assert_refused(p.returncode, p.stderr, folder / "polish.h5",
                   f"file: expected the file the fit was made from (SHA-256 {fit_sha[:12]}… in its fit.json), got "
                   f"changed since (now {sha(folder / 'polish.h5')[:12]}…)")
    assert not (tmp_path / "val2").exists()
