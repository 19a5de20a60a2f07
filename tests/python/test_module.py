"""`import burrbench` (python/, issue 15): the module built by the project's CMake for
/usr/bin/python3, imported from the build tree. Its replay equals the CLI's prediction
file bit for bit, its readers give back what the C++ side wrote, its errors carry the
CLI's one-line message, and it releases the GIL while the model runs."""
import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from synthetic import (BURRBENCH, PLUNGE_TWICE_WARNING, SRC, STAGE_GAP_WARNING, START_IN_BONE_WARNING, drill_plunge_twice,
                       drop_samples, make_synthetic, run_ok, start_late)

sys.path.insert(0, str(Path(os.environ["BURRBENCH_BUILD_DIR"]) / "python"))
import burrbench  # noqa: E402


@pytest.fixture(scope="module")
def exp(tmp_path_factory):
    d = make_synthetic(tmp_path_factory.mktemp("python"))
    run_ok("replay", d / "experiment.toml", "--params", d / "params_true.toml", "--out", d / "pred.h5")
    run_ok("calibrate", d / "experiment.toml", "--out", d / "cal", "--no-cross-validation", "--no-discretization-check",
           "--no-profiles")
    run_ok("validate", d / "experiment.toml", "--params", d / "params_true.toml", "--criteria",
           SRC / "examples" / "criteria" / "release.toml", "--out", d / "gate", "--no-verification")
    return d


def test_replay_equals_the_cli_prediction_bit_for_bit(exp):
    pred = burrbench.replay(exp / "experiment.toml", exp / "params_true.toml")
    with h5py.File(exp / "pred.h5") as f:
        recs = f["recordings"]
        assert sorted(pred) == sorted(recs)
        for rid, rec in pred.items():
            compared = 0
            for name, ds in recs[rid].items():
                if name in rec and len(ds.shape) > 0 and ds.shape[0] > 0:
                    assert np.array_equal(rec[name], ds[()]), (rid, name)
                    compared += 1
            assert compared >= 12, (rid, compared)
            assert np.array_equal(rec["removed_mm3"], recs[rid].attrs["removed_mm3"])
            assert rec["steps"] == recs[rid].attrs["steps"]
            a = recs[rid].attrs  # 2.3: what the replay applied and how each sample counts
            assert rec["role"] == a["role"].decode() and rec["force_bias_source"] == a["force_bias_source"].decode()
            for name in ("lag_ms", "depth_offset_mm", "force_bias_N", "friction_energy_mJ"):
                assert np.array_equal(rec[name], a[name]), (rid, name)
            assert rec.units["force_sensor_pred_N"] == "N" and rec.frames["force_sensor_pred_N"] == "sensor"
            assert rec.frames["centre_vol_mm"] == "volume" and rec.units["centre_vol_mm"] == "mm"
            # Every dataset's unit as the file's @unit says (one table on both sides).
            with_unit = {n: ds.attrs["unit"].decode() for n, ds in recs[rid].items() if "unit" in ds.attrs}
            assert len(with_unit) >= 12
            assert {n: rec.units.get(n) for n in with_unit if n in rec} == {n: u for n, u in with_unit.items() if n in rec}
    # The same constants as a dict give the same numbers.
    params = burrbench.read_params(exp / "params_true.toml")["classes"]
    again = burrbench.replay(exp / "experiment.toml", {k: {q: v[q] for q in ("id", "alpha_N_per_mm2", "c1_N_per_mm2", "mu")}
                                                       for k, v in params.items()}, threads=1)
    for rid in pred:  # one recording at a time predicts what two at once (the default) did
        assert np.array_equal(again[rid]["force_sensor_pred_N"], pred[rid]["force_sensor_pred_N"]), rid
    with pytest.raises(burrbench.InputError, match="threads"):
        burrbench.replay(exp / "experiment.toml", exp / "params_true.toml", threads=0)


def test_every_reader_gives_back_what_the_cpp_side_wrote(exp):
    rec = burrbench.read_recording(exp / "polish.h5")
    with h5py.File(exp / "polish.h5") as f:
        force = f["streams/ft_sensor/channels/force_N"][()]
        notes = f["meta"].attrs["notes"]
    ch = rec["streams"]["ft_sensor"]["channels"]
    assert np.array_equal(ch["force_N"], force) and ch.units["force_N"] == "N"
    assert isinstance(rec["meta"].attrs["notes"], str) and rec["meta"].attrs["notes"] == notes.decode()
    assert rec.attrs["format"] == "burrbench.recording"
    sample = burrbench.read_sample(exp / "sample.h5")
    assert sample.attrs["format"] == "burrbench.sample" and sample.attrs["voxel_size_mm"] == pytest.approx(0.1)
    pred = burrbench.read_prediction(exp / "pred.h5")
    assert pred["recordings"]["polish"].units["force_sensor_pred_N"] == "N"
    fit = burrbench.read_fit(exp / "cal" / "fit.json")
    assert fit == json.loads((exp / "cal" / "fit.json").read_text())
    assert {p["name"] for p in fit["parameters"]} == {"alpha", "c1", "mu"}
    params = burrbench.read_params(exp / "cal" / "params.toml")
    compact = [p for p in fit["parameters"] if p["class_name"] == "compact"]
    for p in compact:
        key = {"alpha": "alpha_N_per_mm2", "c1": "c1_N_per_mm2", "mu": "mu"}[p["name"]]
        assert params["classes"]["compact"][key] == p["held"]
    manifest = burrbench.read_experiment(exp / "experiment.toml")
    assert [r["id"] for r in manifest["recordings"]] == ["plunge", "sweep", "polish"]
    criteria = burrbench.read_criteria(exp / "gate" / "criteria.toml")
    assert criteria["context"]["model_influence"] == "high" and len(criteria["criterion"]) == 4
    metrics = burrbench.read_metrics(exp / "gate" / "metrics.json")
    assert metrics == json.loads((exp / "gate" / "metrics.json").read_text()) and metrics["pass"] is True
    # A table: python3-pandas is installed by scripts/install-deps (imported only here).
    df = pred["recordings"]["polish"].to_pandas()
    assert np.array_equal(df["t_s"].to_numpy(), pred["recordings"]["polish"]["t_s"])
    assert np.array_equal(df["force_sensor_pred_N_z"].to_numpy(), pred["recordings"]["polish"]["force_sensor_pred_N"][:, 2])


def test_an_input_error_raises_with_the_cli_message(exp, tmp_path):
    bad = tmp_path / "params.toml"
    bad.write_text((exp / "params_true.toml").read_text().replace("mu = ", "mu = -", 1))
    p = subprocess.run([BURRBENCH, "replay", exp / "experiment.toml", "--params", bad, "--out", tmp_path / "p.h5"],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2
    line = p.stderr.strip()
    assert line.startswith("burrbench: ")
    with pytest.raises(burrbench.InputError) as e:
        burrbench.replay(exp / "experiment.toml", bad)
    assert str(e.value) == line[len("burrbench: "):]
    assert isinstance(e.value, ValueError)
    with pytest.raises(burrbench.InputError, match="fit.json"):
        burrbench.read_fit(tmp_path / "fit.json")  # missing: named
    with pytest.raises(burrbench.InputError, match="derivatives"):
        burrbench.calibrate(exp / "experiment.toml", derivatives="guess")


@pytest.mark.parametrize("option, value, message", [
    ("threads", "2", "calibrate(): threads: expected an integer, got '2' (str)"),
    ("starts", 2.5, "calibrate(): starts: expected an integer, got 2.5 (float)"),
    ("starts", True, "calibrate(): starts: expected an integer, got True (bool)"),
    ("threads", 2**40, "calibrate(): threads: expected an integer, got 1099511627776 (int)"),
    ("profiles", "no", "calibrate(): profiles: expected True or False, got 'no' (str)"),
    ("profiles", 0, "calibrate(): profiles: expected True or False, got 0 (int)"),
    ("bootstrap_block_s", "1", "calibrate(): bootstrap_block_s: expected a number, got '1' (str)"),
    ("derivatives", 3, 'calibrate(): derivatives: expected "sensitivities" or "fd", got 3 (int)'),
    ("threads", 0, "calibrate(): threads: expected 1..64, got 0"),
    ("max_iterations", 0, "calibrate(): max_iterations: expected 1..1000, got 0"),
    ("progress", 5, "calibrate(): progress: expected a callable progress(fraction, line), or None, got 5 (int)"),
])
def test_a_bad_calibrate_option_is_named_with_what_was_expected(exp, option, value, message):
    # One InputError naming the Python option (not the CLI's --max-iterations) and the
    # expected type: no pybind11 "Unable to cast", no silent 2.5 → 2 or "no" → True.
    with pytest.raises(burrbench.InputError) as e:
        burrbench.calibrate(exp / "experiment.toml", **{option: value})
    assert str(e.value) == message


@pytest.mark.parametrize("call, kwargs, message", [
    ("replay", {"step_us": "5"}, "replay(): step_us: expected a number, got '5' (str)"),
    ("replay", {"step_us": -1.0}, "replay(): step_us: expected a step ≥ 0 (µs; 0 = half the sample period), got -1.0 (float)"),
    ("replay", {"step_us": float("nan")}, "replay(): step_us: expected a step ≥ 0 (µs; 0 = half the sample period), got nan (float)"),
    ("replay", {"threads": 1.5}, "replay(): threads: expected an integer, got 1.5 (float)"),
    ("replay", {"erosion": "no"}, "replay(): erosion: expected True or False, got 'no' (str)"),
    ("replay", {"progress": "yes"}, "replay(): progress: expected a callable progress(fraction, line), or None, got 'yes' (str)"),
    ("contact", {"radius_mm": "1"}, "contact(): radius_mm: expected a number, got '1' (str)"),
    ("contact", {"radius_mm": 0.0}, "contact(): radius_mm: expected a burr radius > 0 (mm), got 0.0 (float)"),
    ("contact", {"p_mm": ["4", "4", "1"]}, "contact(): p_mm: expected 3 finite numbers, got ['4', '4', '1']"),
    ("contact", {"p_mm": [4.0, 4.0]}, "contact(): p_mm: expected 3 finite numbers, got [4.0, 4.0]"),
    ("contact", {"omega_rad_s": [0, 0, float("inf")]}, "contact(): omega_rad_s: expected 3 finite numbers, got [0, 0, inf]"),
    ("contact", {"p_mm": [[4.0, 4.0], [1.0]]}, "contact(): p_mm: expected 3 finite numbers, got [[4.0, 4.0], [1.0]]"),
])
def test_a_bad_replay_or_contact_argument_is_named_with_what_was_expected(exp, call, kwargs, message):
    # As calibrate's options: no silent "5" → 5.0 or 1.5 → 1, no pybind11 "Unable to cast".
    if call == "replay":
        args = {"experiment": exp / "experiment.toml", "params": exp / "params_true.toml", **kwargs}
        f = burrbench.replay
    else:
        args = {"volume": burrbench.Volume.from_sample(exp / "sample.h5"), "params": exp / "params_true.toml",
                "p_mm": [4.0, 4.0, 1.0], "omega_rad_s": [0, 0, 3141.6], "radius_mm": 1.0, **kwargs}
        f = burrbench.contact
    with pytest.raises(burrbench.InputError) as e:
        f(**args)
    assert str(e.value) == message


def test_replay_and_calibrate_warn_of_two_recordings_that_drilled_one_spot(exp, tmp_path):
    # As `burrbench replay` warns on stderr: a UserWarning naming the pair, which a script
    # can turn into an error with the warnings filter.
    import warnings
    manifest = drill_plunge_twice(exp, tmp_path / "twice")
    with pytest.warns(UserWarning) as caught:
        pred = burrbench.replay(manifest, manifest.parent / "params_true.toml")
    said = [str(w.message) for w in caught if "removed the same bone" in str(w.message)]
    assert len(said) == 1 and said[0].startswith(PLUNGE_TWICE_WARNING), said
    assert "plunge_again" in pred and "plunge_listed_again" in pred
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(UserWarning, match="plunge_again"):
            burrbench.replay(manifest, manifest.parent / "params_true.toml")
        burrbench.replay(exp / "experiment.toml", exp / "params_true.toml")  # separate spots: no warning
    # calibrate() too: the warning, also in the summary and among fit.json's warnings.
    with pytest.warns(UserWarning) as caught:
        res = burrbench.calibrate(manifest, starts=1, profiles=False, cross_validate=False,
                                  discretization_check=False)
    said = [str(w.message) for w in caught if "removed the same bone" in str(w.message)]
    assert len(said) == 1 and said[0].startswith(PLUNGE_TWICE_WARNING), said
    assert said[0] in res["fit"]["settings"]["warnings"] and "warning: " + said[0] in res["summary"]


def test_replay_warns_of_force_samples_the_stage_gave_no_position_for(exp, tmp_path):
    # As `burrbench replay` warns on stderr; those samples are out of use.
    manifest, t_a, t_b = drop_samples(exp, tmp_path / "gap")
    with pytest.warns(UserWarning) as caught:
        pred = burrbench.replay(manifest, manifest.parent / "params_true.toml")
    t = pred["sweep"]["t_s"]
    inside = (t > t_a) & (t < t_b)
    said = [str(w.message) for w in caught if str(w.message).startswith(STAGE_GAP_WARNING)]
    assert said == [said[0]] and said[0].startswith(STAGE_GAP_WARNING + f"{inside.sum()} force samples"), said
    assert inside.sum() > 250 and not pred["sweep"]["use"][inside].any() and pred["sweep"]["use"][~inside].all()


def test_replay_warns_of_a_recording_that_begins_in_bone(exp, tmp_path):
    # As `burrbench replay` warns on stderr: the plunge's streams all begin 0.15 mm deep.
    manifest = start_late(exp, tmp_path / "late", 1.3)
    with pytest.warns(UserWarning) as caught:
        burrbench.replay(manifest, manifest.parent / "params_true.toml")
    said = [str(w.message) for w in caught if str(w.message).startswith(START_IN_BONE_WARNING)]
    assert len(said) == 1 and "mm deep in the bone of sample S1" in said[0], said


def test_calibrate_gives_each_of_its_warnings_as_a_userwarning(exp, tmp_path):
    # The lines the CLI's summary prints as "warning:", each once: here the plunge's streams
    # begin 0.15 mm deep in bone, and the fit's misfit follows from it.
    manifest = start_late(exp, tmp_path / "late", 1.3)
    with pytest.warns(UserWarning) as caught:
        res = burrbench.calibrate(manifest, starts=1, profiles=False, cross_validate=False,
                                  discretization_check=False)
    said = [str(w.message) for w in caught]
    assert said == res["fit"]["settings"]["warnings"] and len(said) >= 2, said
    assert [w for w in said if w.startswith(START_IN_BONE_WARNING)], said
    assert [line[len("warning: "):] for line in res["summary"].splitlines() if line.startswith("warning: ")] == said


def test_replay_from_python_with_progress(exp):
    # The lines `burrbench replay` prints, the experiment's fraction rising to 1; the same
    # prediction as without a callback.
    lines = []
    pred = burrbench.replay(exp / "experiment.toml", exp / "params_true.toml",
                            progress=lambda f, line: lines.append((f, line)))
    fractions = [f for f, _ in lines if f is not None]
    assert len(fractions) >= 3 and fractions[-1] == 1.0 and all(0 <= f <= 1 for f in fractions), lines
    assert any("plunge" in line for _, line in lines), lines
    plain = burrbench.replay(exp / "experiment.toml", exp / "params_true.toml")
    for rid in plain:
        assert np.array_equal(plain[rid]["force_sensor_pred_N"], pred[rid]["force_sensor_pred_N"]), rid


def test_numpy_scalars_are_good_calibrate_options(exp):
    out = burrbench.calibrate(exp / "experiment.toml", starts=np.int64(2), profiles=np.bool_(False),
                              cross_validate=False, discretization_check=False, bootstrap_block_s=np.float64(1.0))
    assert out["fit"]["settings"]["global_search"]["starts"] == 2
    assert out["fit"]["settings"]["depth_check"]["computed"]  # on by default, as in the CLI


def test_the_depth_check_can_be_left_out(exp):
    out = burrbench.calibrate(exp / "experiment.toml", starts=1, profiles=False, cross_validate=False,
                              discretization_check=False, depth_check=False)
    assert out["fit"]["settings"]["depth_check"] == {"computed": False}
    with pytest.raises(burrbench.InputError, match="depth_check"):
        burrbench.calibrate(exp / "experiment.toml", depth_check="no")


def test_volume_and_contact_agree_with_the_sample_and_its_partials(exp):
    s = burrbench.read_sample(exp / "sample.h5")
    v1 = burrbench.Volume.from_sample(exp / "sample.h5")
    labels, chi = s["labels"], s["fraction"]
    v2 = burrbench.Volume.from_arrays(labels, chi, s.attrs["voxel_size_mm"], s.attrs["origin_mm"])
    assert v1.shape_zyx == v2.shape_zyx == labels.shape
    params = exp / "params_true.toml"
    top = s.attrs["origin_mm"][2] + s.attrs["voxel_size_mm"] * (labels.shape[0] - 1)
    p = [4.0, 4.0, top - 0.3]  # 0.3 mm into the top face (compact layer)
    c1 = burrbench.contact(v1, params, p, [0, 0, 3141.6], 1.0)
    c2 = burrbench.contact(v2, params, p, [0, 0, 3141.6], 1.0)
    assert np.array_equal(c1["force_N"], c2["force_N"]) and c1["bone_volume_mm3"] > 0
    classes = burrbench.read_params(params)["classes"]
    fe = sum(c["c1_N_per_mm2"] * c1["dF_dC1"][c["id"]] for c in classes.values())
    fmu = sum(c["mu"] * c1["dFmu_dmu"][c["id"]] for c in classes.values())
    assert np.allclose(fe, c1["elastic_N"], rtol=1e-12, atol=1e-12)
    assert np.allclose(fmu, c1["friction_N"], rtol=1e-12, atol=1e-12)


def test_the_gil_is_released_while_replaying(exp):
    # Behaviour, not speed (the speed-up of two threads is measured in bench/python.sh):
    # while one thread replays, this thread keeps running Python. Were the GIL held for
    # the call, this thread could not tick between the call's start and end and the
    # longest gap would be the whole replay; released, gaps are scheduler slices.
    args = (exp / "experiment.toml", exp / "params_true.toml", 25.0)  # a finer step: ~1 s
    span = {}

    def work():
        span["start"] = time.perf_counter()
        burrbench.replay(*args)
        span["end"] = time.perf_counter()

    worker = threading.Thread(target=work)
    ticks = []
    worker.start()
    while worker.is_alive():
        ticks.append(time.perf_counter())
        time.sleep(0.001)
    worker.join()
    duration = span["end"] - span["start"]
    inside = [span["start"]] + [t for t in ticks if span["start"] < t < span["end"]] + [span["end"]]
    longest_gap = max(b - a for a, b in zip(inside, inside[1:]))
    print(f"replay {duration:.3f} s, {len(inside) - 2} ticks of this thread meanwhile, longest gap {longest_gap:.3f} s")
    assert duration > 0.2, duration
    assert longest_gap < 0.5 * duration, (duration, longest_gap)


def test_calibrate_from_python_with_progress(exp):
    lines = []
    out = burrbench.calibrate(exp / "experiment.toml", progress=lambda f, line: lines.append((f, line)),
                              starts=2, profiles=False, cross_validate=False, discretization_check=False)
    # Every line carries the whole run's fraction (from its stages' planned replays): never
    # None, in [0, 1], never falling, 1 at the end and only there.
    fractions = [f for f, _ in lines]
    assert lines and None not in fractions, lines[:5]
    assert all(0 <= f <= 1 for f in fractions) and fractions == sorted(fractions), fractions
    assert fractions[-1] == 1.0 and fractions.count(1.0) == 1 and lines[-1][1].startswith("fitted: "), lines[-3:]
    assert len(set(fractions)) >= 5, fractions  # it moves along, not 0 then 1
    assert any("global search" in line for _, line in lines)
    fit = out["fit"]
    assert fit["format"] == "burrbench.fit"
    truth = burrbench.read_params(exp / "params_true.toml")["classes"]["compact"]
    got = out["params"]["compact"]
    assert got["c1_N_per_mm2"] == pytest.approx(truth["c1_N_per_mm2"], rel=0.02)
    assert got["mu"] == pytest.approx(truth["mu"], rel=0.05)
    assert "compact" in out["summary"]


def test_the_example_script_runs(exp, tmp_path):
    env = {**os.environ, "PYTHONPATH": str(Path(os.environ["BURRBENCH_BUILD_DIR"]) / "python")}
    p = subprocess.run(["/usr/bin/python3", SRC / "examples" / "python" / "quickstart.py", exp / "experiment.toml",
                        exp / "params_true.toml", "--plot", tmp_path / "force.png"],
                       capture_output=True, text=True, timeout=300, env=env)
    assert p.returncode == 0, p.stderr
    assert "polish:" in p.stdout and "with mu x1.2" in p.stdout
    assert (tmp_path / "force.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("labels, message", [
    (np.full((3, 3, 3), 1.0), "labels: expected an integer array (uint8: 0 = empty, 1..255 a class), got float64"),
    (np.ones((3, 3, 3), bool), "labels: expected an integer array (uint8: 0 = empty, 1..255 a class), got bool"),
    (np.full((3, 3, 3), 257, np.int32), "labels (flat index 0): expected a label 0..255, got 257"),
    (np.full((3, 3, 3), -1, np.int16), "labels (flat index 0): expected a label 0..255, got -1"),
])
def test_labels_are_taken_as_given_or_refused(labels, message):
    # A cast to uint8 would have made 257 → 1 (compact) and 1.7 → 1 without a word.
    with pytest.raises(burrbench.InputError) as e:
        burrbench.Volume.from_arrays(labels, np.ones((3, 3, 3), np.float32), 0.1, [0, 0, 0])
    assert str(e.value) == "Volume.from_arrays: " + message
    # Integer labels of any width within 0..255 are fine.
    v = burrbench.Volume.from_arrays(np.ones((3, 3, 3), np.int64), np.ones((3, 3, 3)), 0.1, [0, 0, 0])
    assert v.shape_zyx == (3, 3, 3)
