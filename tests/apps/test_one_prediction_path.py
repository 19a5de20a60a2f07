"""One path from model to prediction (issue 14): `replay`, `validate` and `calibrate` (at
its optimum) all replay through model::predict_experiment and write the same
prediction.h5 format; what each applied (fitted bias and lag, or the tare) is recorded in
the file, and the CSVs and analysis input beside it are exports of that one prediction."""
import json
import subprocess
import tomllib

import h5py
import numpy as np
import pytest

from synthetic import BURRBENCH, SRC, make_synthetic, run_ok
from report_context import context

CRITERIA = SRC / "examples" / "criteria" / "release.toml"


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    d = make_synthetic(tmp_path_factory.mktemp("onepath"))
    run_ok("replay", d / "experiment.toml", "--params", d / "params_true.toml", "--out", d / "replay.h5")
    for name, extra in (("raw", ["--no-tare"]), ("tared", [])):
        # Without the tare the recordings' bias fails the gate (exit 1): the outputs stand.
        p = subprocess.run([BURRBENCH, "validate", d / "experiment.toml", "--params", d / "params_true.toml",
                            "--criteria", CRITERIA, "--out", d / name, "--no-verification", *extra],
                           capture_output=True, text=True, timeout=600)
        assert p.returncode == (1 if extra else 0), p.stdout + p.stderr
    run_ok("calibrate", d / "experiment.toml", "--out", d / "cal", "--no-cross-validation",
           "--no-discretization-check", "--no-profiles")
    return d


def recordings(path):
    with h5py.File(path) as f:
        out = {}
        for rid, g in f["recordings"].items():
            rec = {k: g[k][()] for k in g}
            rec.update({k: (v.decode() if isinstance(v, bytes) else v) for k, v in g.attrs.items()})
            out[rid] = rec
        removed = {sid: {"depth": s["removed_depth_mm"][()], **dict(s.attrs)} for sid, s in f.get("samples", {}).items()}
        return out, removed, f.attrs["format_version"]


def test_validate_without_tare_predicts_what_replay_predicts_bit_for_bit(runs):
    plain, plain_removed, _ = recordings(runs / "replay.h5")
    gate, removed, version = recordings(runs / "raw" / "prediction.h5")
    assert str(version.decode() if isinstance(version, bytes) else version).startswith("2.4")
    assert sorted(plain) == sorted(gate) == ["plunge", "polish", "sweep"]
    for rid in plain:
        for key in ("force_sensor_pred_N", "force_burr_vol_N", "centre_vol_mm", "torque_sensor_pred_Nmm"):
            assert np.array_equal(plain[rid][key], gate[rid][key]), (rid, key)
        assert gate[rid]["force_bias_source"] == "none" and np.all(gate[rid]["force_bias_N"] == 0)
        assert gate[rid]["role"] == ("validate" if rid == "polish" else "calibrate")
        assert not plain_removed  # a plain replay keeps no removed-bone map
    # The gate's prediction carries the removed bone the report draws.
    (sample,) = context(runs / "raw")["samples"]
    assert removed[sample]["removed_volume_mm3"] > 0


def test_the_tare_is_recorded_and_added_to_the_prediction(runs):
    plain, _, _ = recordings(runs / "replay.h5")
    tared, _, _ = recordings(runs / "tared" / "prediction.h5")
    for rid, rec in tared.items():
        assert rec["force_bias_source"] == "tare"
        # The synthetic recordings carry a bias of (0.05, -0.03, 0.1) N and σ = 0.02 N.
        assert np.allclose(rec["force_bias_N"], [0.05, -0.03, 0.1], atol=0.01), (rid, rec["force_bias_N"])
        assert np.allclose(rec["force_sensor_pred_N"] - plain[rid]["force_sensor_pred_N"], rec["force_bias_N"],
                           rtol=0, atol=1e-12)


def test_calibrate_writes_the_prediction_at_its_optimum_with_the_fitted_nuisances(runs):
    fit = json.loads((runs / "cal" / "fit.json").read_text())
    nuisance = {(n["recording_id"], n["name"]): n["estimate"] for n in fit["nuisance"]}
    pred, removed, _ = recordings(runs / "cal" / "prediction.h5")
    for rid in ("plunge", "sweep"):
        rec = pred[rid]
        assert rec["force_bias_source"] == "fit"
        assert list(rec["force_bias_N"]) == [nuisance[(rid, f"bias_{a}")] for a in "xyz"]
        if (rid, "lag") in nuisance:
            assert rec["lag_ms"] == nuisance[(rid, "lag")]
        assert rec["used_calibrate"].sum() > 0 and rec["used_validate"].sum() == 0
        assert rec["band95_N"].shape == rec["force_sensor_pred_N"].shape and rec["band95_N"].max() > 0
    # The held-out polish has no fitted bias: it gets the tare, and counts for the gate only.
    assert pred["polish"]["force_bias_source"] == "tare"
    assert pred["polish"]["used_validate"].sum() > 0 and pred["polish"]["used_calibrate"].sum() == 0
    # Energy balance survives the hand-off: α·removed = ∫ΣW dt per class.
    params = {c["class_name"]: c for c in context(runs / "cal")["parameters"]}
    for rid, rec in pred.items():
        for label, c in ((1, params.get("compact")), (2, params.get("trabecular"))):
            if c and rec["removed_mm3"][label] > 0:
                assert rec["friction_energy_mJ"][label] == pytest.approx(c["alpha_N_per_mm2"] * rec["removed_mm3"][label],
                                                                         rel=1e-6)
    assert removed


def test_recordings_replayed_at_once_predict_what_one_at_a_time_predicts(runs, tmp_path):
    """--threads replays several recordings at once (the default, 2); each starts from its
    sample as scanned, so the prediction, its band and the removed bone must not change."""
    cal = runs / "cal"
    outs = {}
    for threads in ("1", "3"):
        run_ok("replay", runs / "experiment.toml", "--params", runs / "params_true.toml",
               "--out", tmp_path / f"replay{threads}.h5", "--threads", threads)
        p = subprocess.run([BURRBENCH, "validate", runs / "experiment.toml", "--params", cal / "params.toml",
                            "--fit", cal / "fit.json", "--criteria", CRITERIA, "--out", tmp_path / f"v{threads}",
                            "--no-verification", "--threads", threads],
                           capture_output=True, text=True, timeout=600)
        assert p.returncode in (0, 1), p.stdout + p.stderr
        outs[threads] = p
    # Progress names the recording each line is about.
    assert "sweep: " in outs["3"].stderr
    plain, _, _ = recordings(runs / "replay.h5")
    for threads in ("1", "3"):
        other, _, _ = recordings(tmp_path / f"replay{threads}.h5")
        for rid in plain:
            for key in ("force_sensor_pred_N", "torque_sensor_pred_Nmm", "buried", "removed_mm3"):
                assert np.array_equal(plain[rid][key], other[rid][key]), (threads, rid, key)
    one, one_removed, _ = recordings(tmp_path / "v1" / "prediction.h5")
    three, three_removed, _ = recordings(tmp_path / "v3" / "prediction.h5")
    assert sorted(one) == sorted(three) == ["plunge", "polish", "sweep"]
    for rid in one:
        assert one[rid]["band95_N"].max() > 0, rid
        for key in ("force_sensor_pred_N", "band95_N", "force_bias_N", "friction_energy_mJ"):
            assert np.array_equal(one[rid][key], three[rid][key]), (rid, key)
    assert sorted(one_removed) == sorted(three_removed) and one_removed
    for sid in one_removed:
        assert np.array_equal(one_removed[sid]["depth"], three_removed[sid]["depth"]), sid
        assert one_removed[sid]["removed_volume_mm3"] == three_removed[sid]["removed_volume_mm3"] > 0


@pytest.mark.parametrize("threads", ["0", "65"])  # 1..model::kMaxThreads (64)
@pytest.mark.parametrize("verb", ["replay", "validate", "verify", "calibrate"])
def test_threads_out_of_range_is_one_line_and_exit_2(runs, tmp_path, verb, threads):
    extra = {"validate": ["--criteria", CRITERIA], "calibrate": []}.get(verb, ["--params", runs / "params_true.toml"])
    if verb == "validate":
        extra += ["--params", runs / "params_true.toml"]
    p = subprocess.run([BURRBENCH, verb, runs / "experiment.toml", "--out", tmp_path / "x", "--threads", threads,
                        *extra], capture_output=True, text=True, timeout=60)
    assert p.returncode == 2, p.stderr
    assert len(p.stderr.strip().splitlines()) == 1 and "--threads" in p.stderr, p.stderr
    assert not (tmp_path / "x").exists()


def test_a_failing_replay_names_the_first_recording_listed_whatever_the_threads(runs, tmp_path):
    """A step too small for any recording fails every replay. The error names --step-us and
    the first recording in the manifest, as one replay after the other would, with one thread or
    three (the longest recording starts first), and writes nothing."""
    first = tomllib.loads((runs / "experiment.toml").read_text())["recordings"][0]["id"]
    errors = {}
    for threads in ("1", "3"):
        out = tmp_path / f"x{threads}.h5"
        p = subprocess.run([BURRBENCH, "replay", runs / "experiment.toml", "--params", runs / "params_true.toml",
                            "--out", out, "--threads", threads, "--step-us", "1e-9"],
                           capture_output=True, text=True, timeout=120)
        assert p.returncode == 2, p.stderr
        errors[threads] = p.stderr.strip().splitlines()[-1]
        # Named as the user typed it, not as the model's field step_s in seconds.
        assert errors[threads].startswith(f"burrbench: command line: --step-us (recording {first}): "), errors[threads]
        assert "got 1e-09 µs" in errors[threads] and "step_s" not in errors[threads], errors[threads]
        assert not out.exists()
    assert errors["1"] == errors["3"]
