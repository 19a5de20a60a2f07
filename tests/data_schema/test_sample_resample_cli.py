"""`burrbench sample resample`: the same sample at voxels split or merged by an integer
factor; merge after split gives the file's voxels back; bad arguments are refused with one
line and an existing output is kept."""
import os
import subprocess

import h5py
import numpy as np

from bad_input import assert_refused

BURRBENCH = os.environ["BURRBENCH"]


def run(*args):
    return subprocess.run([BURRBENCH, *map(str, args)], capture_output=True, text=True, timeout=120)


def test_split_then_merge_gives_the_sample_back(tmp_path):
    s = tmp_path / "s.h5"
    assert run("sample", "synth", "--extent-mm", "2,2,1", "--voxel-mm", "0.1", "--out", s).returncode == 0
    p = run("sample", "resample", s, "--split", "2", "--out", tmp_path / "half.h5")
    assert p.returncode == 0 and "voxels of 0.05 mm (from 0.1 mm, split by 2)" in p.stdout, p.stdout + p.stderr
    # Progress on stderr (a lab CT split takes minutes): the step, the write, the voxels made.
    lines = p.stderr.splitlines()
    assert lines[0].startswith("resample: split: every voxel into 8 [") and \
        lines[1].startswith(f"resample: write: {tmp_path / 'half.h5'} [") and \
        lines[2].startswith(f"resample: {20 * 20 * 10 * 8} voxels ["), p.stderr
    p = run("sample", "resample", tmp_path / "half.h5", "--merge", "2", "--out", tmp_path / "back.h5")
    assert p.returncode == 0, p.stdout + p.stderr
    with h5py.File(s) as a, h5py.File(tmp_path / "half.h5") as h, h5py.File(tmp_path / "back.h5") as b:
        assert h["labels"].shape == tuple(2 * n for n in a["labels"].shape)
        assert h.attrs["voxel_size_mm"] == a.attrs["voxel_size_mm"] / 2
        # The same bone volume at both sizes, and the original voxels back after the merge.
        total = np.sum(a["fraction"][:], dtype=np.float64)
        assert abs(np.sum(h["fraction"][:], dtype=np.float64) / 8 - total) < 1e-9 * total
        np.testing.assert_array_equal(b["labels"][:], a["labels"][:])
        np.testing.assert_allclose(b["fraction"][:], a["fraction"][:], atol=1e-6)
        np.testing.assert_allclose(b.attrs["origin_mm"], a.attrs["origin_mm"], atol=1e-12)
        assert b.attrs["voxel_size_mm"] == a.attrs["voxel_size_mm"]


def test_bad_arguments_are_refused_and_outputs_kept(tmp_path):
    s = tmp_path / "s.h5"
    assert run("sample", "synth", "--extent-mm", "1,1,1", "--voxel-mm", "0.1", "--out", s).returncode == 0
    out = tmp_path / "o.h5"
    p = run("sample", "resample", s, "--out", out)
    assert_refused(p.returncode, p.stderr, "command line", "exactly one of --split N or --merge N")
    p = run("sample", "resample", s, "--split", "2", "--merge", "2", "--out", out)
    assert_refused(p.returncode, p.stderr, "command line", "exactly one of")
    p = run("sample", "resample", s, "--merge", "1", "--out", out)
    assert_refused(p.returncode, p.stderr, "command line", "--merge", "2..16")
    assert not out.exists()
    out.write_text("mine")
    p = run("sample", "resample", s, "--split", "2", "--out", out)
    assert_refused(p.returncode, p.stderr, "o.h5", "--overwrite")
    assert out.read_text() == "mine"
    p = run("sample", "resample", s, "--split", "2", "--out", s)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
