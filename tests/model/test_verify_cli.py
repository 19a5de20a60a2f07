"""`burrbench verify` (solution verification, docs/calibration.md): every recording is
replayed at l, l/2, 2l and Δt/2; the printed table and the JSON agree, the Richardson
estimate follows from the changes, and the verdict compares it with the sensor noise."""
import json
import math
import os
import subprocess
from pathlib import Path

import pytest

from synthetic import make_synthetic, run_ok

from bad_input import assert_refused

BURRBENCH = os.environ["BURRBENCH"]
SRC = Path(os.environ["BURRBENCH_SOURCE_DIR"])


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory):
    d = tmp_path_factory.mktemp("synthetic_verify")
    make_synthetic(d)
    return d


def verify(d, *extra):
    return subprocess.run([BURRBENCH, "verify", str(d / "experiment.toml"), "--params", str(d / "params_true.toml"),
                           *map(str, extra)], capture_output=True, text=True, timeout=600)


def test_study_levels_richardson_and_verdict(synthetic):
    d = synthetic
    p = verify(d, "--out", d / "v.json")
    assert p.returncode == 0, p.stdout + p.stderr
    v = json.loads((d / "v.json").read_text())
    assert [r["id"] for r in v["recordings"]] == ["plunge", "sweep", "polish"]
    for r in v["recordings"]:
        lv = {x["level"]: x for x in r["levels"]}
        assert list(lv) == ["l", "l/2", "2l", "dt/2"]
        assert (lv["l"]["voxel_mm"], lv["l/2"]["voxel_mm"], lv["2l"]["voxel_mm"]) == pytest.approx((0.1, 0.05, 0.2))
        assert lv["dt/2"]["step_us"] == pytest.approx(lv["l"]["step_us"] / 2)
        assert lv["l"]["rms_change_N"] == 0 and lv["l"]["max_change_N"] == 0
        for name in ("l/2", "2l", "dt/2"):  # the largest change bounds the RMS one (per axis ≤ |ΔF|)
            assert lv[name]["max_change_N"] >= lv[name]["rms_change_N"] > 0
        # The step error: first order from the Δt/2 replay.
        assert r["step_error_N"] == pytest.approx(2 * lv["dt/2"]["rms_change_N"], rel=1e-12)
        assert r["error_N"] == pytest.approx(math.hypot(r["voxel_error_N"], r["step_error_N"]), rel=1e-12)
        # The voxel error is at least the change from l to l/2 (Richardson factor ≥ 1).
        assert r["voxel_error_N"] >= 0.9 * lv["l/2"]["rms_change_N"] > 0
        assert f"{r['id']} ({r['samples']} samples)" in p.stdout
    worst = max(v["recordings"], key=lambda r: r["error_N"])
    assert v["worst_recording"] == worst["id"] and v["largest_error_N"] == worst["error_N"]
    # At R/l = 10 the voxel's error in force is several times the 0.02 N noise.
    assert v["below_noise"] is False and v["largest_error_N"] > v["sigma_N"]
    assert "exceeds the sensor noise" in v["verdict"] and v["verdict"] in p.stdout
    # A noise level given on the command line is used, and turns the verdict.
    q = verify(d, "--sigma-N", 10)
    assert q.returncode == 0 and "is below the sensor noise (10 N)" in q.stdout, q.stdout + q.stderr


def test_a_step_longer_than_the_sample_period_is_cut_to_it(synthetic, tmp_path):
    # A replay takes one sub-step per sample interval at the most, so a longer --step-us
    # was recorded as a step not taken, and its "half step" (still one sub-step) changed
    # nothing: a step error of 0. The step is the sample period (1 ms here), halved for dt/2.
    out = tmp_path / "v.json"
    p = verify(synthetic, "--out", out, "--step-us", 5000)
    assert p.returncode == 0, p.stdout + p.stderr
    for r in json.loads(out.read_text())["recordings"]:
        lv = {x["level"]: x for x in r["levels"]}
        assert lv["l"]["step_us"] == pytest.approx(1000, rel=1e-9), r["id"]
        assert lv["dt/2"]["step_us"] == pytest.approx(500, rel=1e-9), r["id"]
        assert lv["dt/2"]["rms_change_N"] > 0 and r["step_error_N"] > 0, r["id"]
    truth = tmp_path / "t.json"
    run_ok("synth", "--sample", synthetic / "sample.h5", "--protocol", SRC / "examples/protocols/plunge.toml",
           "--params", synthetic / "params_true.toml", "--out", tmp_path / "r.h5", "--truth", truth,
           "--step-us", 5000)
    assert json.loads(truth.read_text())["replay_step_s"] == pytest.approx(1e-3, rel=1e-9)


def without_wall(study):
    for r in study["recordings"]:
        for lv in r["levels"]:
            assert lv.pop("wall_s") > 0
    return study


def test_replays_run_at_once_give_the_study_one_at_a_time_gives(synthetic):
    """--threads (default 2) runs the 12 replays (3 recordings × 4 levels) several at once;
    each is independent, so every figure but the wall times is the same, bit for bit."""
    d = synthetic
    studies = {}
    for threads in ("1", "3"):
        p = verify(d, "--out", d / f"v{threads}.json", "--threads", threads)
        assert p.returncode == 0, p.stdout + p.stderr
        studies[threads] = without_wall(json.loads((d / f"v{threads}.json").read_text()))
    assert studies["1"] == studies["3"]
    assert [r["id"] for r in studies["3"]["recordings"]] == ["plunge", "sweep", "polish"]
    p = verify(d, "--threads", 0)
    assert p.returncode == 2 and "--threads" in p.stderr and len(p.stderr.strip().splitlines()) == 1, p.stderr


def test_a_failing_replay_names_the_first_recording_and_level_whatever_the_threads(synthetic):
    """A step too small for any replay fails all 12. The error names the first in recording
    and level order (plunge at l), as one replay after the other would, though the l/2
    replays start first; exit 2 and no study written."""
    d = synthetic
    lines = {}
    for threads in ("1", "3"):
        out = d / f"failed{threads}.json"
        p = verify(d, "--out", out, "--threads", threads, "--step-us", "1e-9")
        assert p.returncode == 2, p.stdout + p.stderr
        lines[threads] = p.stderr.strip().splitlines()[-1]
        assert "--step-us (recording plunge at l)" in lines[threads], lines[threads]
        assert not out.exists()
    assert lines["1"] == lines["3"]


def test_verify_refuses_bad_input_and_keeps_existing_output(synthetic):
    d = synthetic
    (d / "keep.json").write_text("mine")
    p = verify(d, "--out", d / "keep.json")
    assert_refused(p.returncode, p.stderr, "keep.json", "--overwrite")
    assert (d / "keep.json").read_text() == "mine"
    p = verify(d, "--step-us", -1)
    assert_refused(p.returncode, p.stderr, "command line", "--step-us")


def test_the_part_within_reach_gives_the_whole_samples_figures(synthetic, tmp_path):
    # Replays at every level use only the voxels within reach of the burr (its radius and 4
    # voxels round every centre, corners on even voxels so that merging by 2 groups the same
    # voxels): the same study as on the whole sample, to rounding, from fewer voxels.
    d = synthetic
    for name, extra in (("part", ()), ("whole", ("--whole-sample",))):
        p = verify(d, "--out", tmp_path / f"{name}.json", *extra)
        assert p.returncode == 0, p.stdout + p.stderr
    part = json.loads((tmp_path / "part.json").read_text())
    whole = json.loads((tmp_path / "whole.json").read_text())
    (reach,) = part["reach"]
    assert reach["dims"] == whole["reach"][0]["dims"] == whole["reach"][0]["replayed_dims"]
    kept = math.prod(reach["replayed_dims"]) / math.prod(reach["dims"])
    assert kept < 0.8, reach  # the synthetic drilling reaches part of its sample

    def numbers(x, path=""):
        if isinstance(x, dict):
            for k, v in x.items():
                if k not in ("wall_s", "reach"):
                    yield from numbers(v, f"{path}/{k}")
        elif isinstance(x, list):
            for i, v in enumerate(x):
                yield from numbers(v, f"{path}[{i}]")
        elif isinstance(x, (int, float)) and not isinstance(x, bool):
            yield path, x
    a, b = dict(numbers(part)), dict(numbers(whole))
    assert a.keys() == b.keys() and len(a) > 50
    for k in a:
        assert a[k] == pytest.approx(b[k], rel=1e-9, abs=1e-12), k
    assert part["verdict"] == whole["verdict"]


def test_quadrature_is_chosen_recorded_and_checked(synthetic):
    """`--quadrature cube` runs the cube quadrature (docs/model.md): its study names it, its
    force differs from the lens's (another quadrature of the same integrals) but not by more
    than the lens's own voxel error, and a replay's prediction.h5 records it per recording."""
    import h5py
    d = synthetic
    p = verify(d, "--quadrature", "cube", "--out", d / "cube.json")
    assert p.returncode == 0, p.stdout + p.stderr
    assert "(cube quadrature)" in p.stdout
    cube = json.loads((d / "cube.json").read_text())
    assert cube["quadrature"] == "cube"
    assert verify(d, "--out", d / "lens.json").returncode == 0
    lens = json.loads((d / "lens.json").read_text())
    assert lens["quadrature"] == "lens"
    for a, b in zip(lens["recordings"], cube["recordings"]):
        assert a["levels"][0]["peak_N"] != b["levels"][0]["peak_N"]
        assert abs(a["levels"][0]["peak_N"] - b["levels"][0]["peak_N"]) < a["voxel_error_N"] + b["voxel_error_N"]
    for q in ("lens", "cube"):
        out = d / f"replay_{q}.h5"
        r = subprocess.run([BURRBENCH, "replay", str(d / "experiment.toml"), "--params", str(d / "params_true.toml"),
                            "--quadrature", q, "--out", str(out)], capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, r.stdout + r.stderr
        with h5py.File(out, "r") as f:
            assert f.attrs["format_version"] in (b"2.4", "2.4")
            for rec in f["recordings"].values():
                v = rec.attrs["quadrature"]
                assert (v.decode() if isinstance(v, bytes) else v) == q
    bad = verify(d, "--quadrature", "sphere")
    assert_refused(bad.returncode, bad.stderr, "command line", "--quadrature", "lens or cube")
