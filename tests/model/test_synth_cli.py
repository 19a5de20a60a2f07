"""End to end through the CLI: `burrbench synth` and `burrbench replay` on the shipped
synthetic reference experiment (examples/experiments/synthetic/make.sh)."""
import json
import os
import subprocess
from pathlib import Path

import h5py
import numpy as np
import pytest
from bad_input import assert_refused
from file_size_limit import burrbench_lines, run_with_file_size_limit
from synthetic import PLUNGE_TWICE_WARNING, drill_plunge_twice

BURRBENCH = os.environ["BURRBENCH"]
SRC = Path(os.environ["BURRBENCH_SOURCE_DIR"])
EXAMPLE = SRC / "examples" / "experiments" / "synthetic"
PROTOCOLS = SRC / "examples" / "protocols"


def run(*args, check=True):
    p = subprocess.run([BURRBENCH, *map(str, args)], capture_output=True, text=True, timeout=300)
    if check and p.returncode != 0:
        raise AssertionError(f"{args}: rc={p.returncode}\n{p.stderr}")
    return p


@pytest.fixture(scope="module")
def exp(tmp_path_factory):
    out = tmp_path_factory.mktemp("synthetic")
    subprocess.run(["sh", str(EXAMPLE / "make.sh"), BURRBENCH, str(out)], check=True,
                   capture_output=True, timeout=300)
    return out


def forces(path):
    with h5py.File(path, "r") as f:
        return f["streams/ft_sensor/channels/force_N"][()]


def synth(exp, out, *extra, protocol="plunge"):
    return run("synth", "--sample", exp / "sample.h5", "--protocol", PROTOCOLS / f"{protocol}.toml",
               "--params", exp / "params_true.toml", "--out", out, "--truth", str(out) + ".json", *extra)


def test_replay_with_true_params_and_lag_leaves_bias_plus_noise(exp):
    text = (exp / "experiment.toml").read_text()
    # the sweeps were synthesised with a 2 ms lag: tell the replay
    parts = text.split("[[recordings]]")
    parts = [parts[0]] + [p.replace("lag_ms = 0.0", "lag_ms = 2.0") if 'id = "plunge"' not in p else p
                          for p in parts[1:]]
    (exp / "lagged.toml").write_text("[[recordings]]".join(parts))
    p = run("replay", "--experiment", exp / "lagged.toml", "--params", exp / "params_true.toml",
            "--out", exp / "pred.h5", "--csv", exp / "pred.csv")
    assert "samples" in p.stdout and "buried" in p.stdout and "removed" in p.stdout and "wall" in p.stdout
    with h5py.File(exp / "pred.h5", "r") as f:
        # fixed-length UTF-8 strings: h5py gives bytes
        assert f.attrs["format"].decode() == "burrbench.prediction"
        inputs = zip(f["provenance/inputs/path"].asstr()[()], f["provenance/inputs/sha256"].asstr()[()])
        assert any(path.endswith("sweep.h5") and len(sha) == 64 for path, sha in inputs)
        total = 0
        for rid in ("plunge", "sweep", "polish"):
            g = f["recordings"][rid]
            truth = json.loads((exp / f"{rid}.truth.json").read_text())
            d = g["force_sensor_meas_N"][()] - g["force_sensor_pred_N"][()]
            n = d.shape[0]
            total += n
            assert np.allclose(d.mean(axis=0), truth["bias_N"], atol=4 * truth["noise_N"] / np.sqrt(n))
            assert np.allclose(d.std(axis=0), truth["noise_N"], rtol=0.08)
            assert np.abs(g["force_sensor_pred_N"][()]).max() > 0.2  # real contact forces
            removed = g.attrs["removed_mm3"]
            assert removed[1] == pytest.approx(truth["removed_mm3_by_class"]["compact"], rel=1e-9)
            # force on the sample = −force on the burr (identity frames)
            assert np.array_equal(g["force_sensor_pred_N"][()], -g["force_burr_vol_N"][()])
            for name in ("depth_b_mm", "normal_vol", "class_mask", "buried", "use", "centre_vol_mm", "t_s"):
                assert g[name].shape[0] == n
    lines = (exp / "pred.csv").read_text().splitlines()
    assert lines[0].startswith("recording_id,t_s,force_burr_vol_N_x")
    assert len(lines) == 1 + total


def test_noiseless_synth_is_reproduced_by_replay(exp, tmp_path):
    rec = tmp_path / "clean.h5"
    synth(exp, rec, "--lag-ms", "4.5", protocol="sweep")
    man = (exp / "experiment.toml").read_text().split("[[recordings]]")[0]
    man = man.replace('path = "sample.h5"', f'path = "{exp / "sample.h5"}"')
    man += f'[[recordings]]\nid = "clean"\npath = "{rec}"\nsample = "S1"\nlag_ms = 4.5\n' \
           '[recordings.registration]\nrotation = [[1,0,0],[0,1,0],[0,0,1]]\ntranslation_mm = [0,0,0]\n'
    (tmp_path / "e.toml").write_text(man)
    run("replay", "--experiment", tmp_path / "e.toml", "--params", exp / "params_true.toml",
        "--out", tmp_path / "p.h5")
    with h5py.File(tmp_path / "p.h5", "r") as f:
        g = f["recordings/clean"]
        meas, pred = g["force_sensor_meas_N"][()], g["force_sensor_pred_N"][()]
    scale = np.abs(meas).max()
    assert scale > 0.2
    assert np.abs(meas - pred).max() <= 1e-9 * scale


def test_same_seed_same_data_other_seed_other_noise(exp, tmp_path):
    a, b, c = tmp_path / "a.h5", tmp_path / "b.h5", tmp_path / "c.h5"
    synth(exp, a, "--noise-N", "0.1", "--seed", "3")
    synth(exp, b, "--noise-N", "0.1", "--seed", "3")
    synth(exp, c, "--noise-N", "0.1", "--seed", "4")
    fa, fb, fc = forces(a), forces(b), forces(c)
    assert fa.tobytes() == fb.tobytes()
    assert not np.any(fa == fc)
    with h5py.File(a, "r") as f, h5py.File(b, "r") as g:
        for s in ("stage", "spindle", "ft_sensor"):
            assert f[f"streams/{s}/t_ns"][()].tobytes() == g[f"streams/{s}/t_ns"][()].tobytes()
    truth = json.loads(Path(str(a) + ".json").read_text())
    assert truth["format"] == "burrbench.synth_truth" and truth["seed"] == 3 and truth["noise_N"] == 0.1
    assert {c["name"] for c in truth["params"]["classes"]} == {"compact", "trabecular"}
    assert len(truth["provenance"]["inputs"]) == 3


def test_bias_and_lag_in_the_output(exp, tmp_path):
    a, b = tmp_path / "a.h5", tmp_path / "b.h5"
    synth(exp, a)
    synth(exp, b, "--bias-N", "0.5,-0.25,1", "--lag-ms", "10")
    fa, fb = forces(a), forces(b)
    # b(t) = a(t − 10 ms) + bias at 1 kHz
    assert np.allclose(fb[10:] - [0.5, -0.25, 1.0], fa[:-10], rtol=0, atol=1e-9 * np.abs(fa).max())
    assert np.allclose(fb[:10], [0.5, -0.25, 1.0], atol=1e-12)  # burr still clear of bone


@pytest.mark.parametrize("edit, message", [
    (("depth_mm = 0.25", "depth_m = 0.25"), "moves[0].depth_m"),
    (('type = "plunge"', 'type = "drill"'), "moves[0].type"),
    (("spin_sign = 1", "spin_sign = 0"), "burr.spin_sign"),
    (("point_mm = [2.5, 5.5, 4.5]", "point_mm = [2.5, 5.5, 2.5]"), "start.point_mm"),
])
def test_bad_protocol_exits_2_with_the_key(exp, tmp_path, edit, message):
    text = (PROTOCOLS / "plunge.toml").read_text()
    assert edit[0] in text
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace(edit[0], edit[1]))
    p = run("synth", "--sample", exp / "sample.h5", "--protocol", bad, "--params", exp / "params_true.toml",
            "--out", tmp_path / "r.h5", "--truth", tmp_path / "t.json", check=False)
    assert p.returncode == 2, p.stderr
    assert message in p.stderr and str(bad) in p.stderr
    assert not (tmp_path / "r.h5").exists()


def test_bad_manifest_and_arguments_exit_2(exp, tmp_path):
    text = (exp / "experiment.toml").read_text()
    bad = exp / "bad_manifest.toml"
    bad.write_text(text.replace('measures = "force_on_sample"', 'measures = "force_on_sensor"'))
    p = run("replay", "--experiment", bad, "--params", exp / "params_true.toml", "--out", tmp_path / "p.h5",
            check=False)
    assert_refused(p.returncode, p.stderr, bad, "sensor.measures")
    bad.write_text(text.replace('path = "sweep.h5"', 'path = "missing.h5"'))
    p = run("replay", "--experiment", bad, "--params", exp / "params_true.toml", "--out", tmp_path / "p.h5",
            check=False)
    assert_refused(p.returncode, p.stderr, "missing.h5")
    assert not (tmp_path / "p.h5").exists()
    p = run("synth", "--sample", exp / "sample.h5", "--protocol", PROTOCOLS / "plunge.toml", "--params",
            exp / "params_true.toml", "--out", tmp_path / "r.h5", "--truth", tmp_path / "t.json",
            "--bias-N", "0.1,0.2", check=False)
    assert p.returncode == 2  # CLI parse error: three values expected
    # an output that is one of the inputs is refused, the input left untouched
    before = (exp / "params_true.toml").read_bytes()
    p = run("synth", "--sample", exp / "sample.h5", "--protocol", PROTOCOLS / "plunge.toml", "--params",
            exp / "params_true.toml", "--out", tmp_path / "r.h5", "--truth", exp / "params_true.toml", check=False)
    assert p.returncode == 2 and (exp / "params_true.toml").read_bytes() == before


@pytest.mark.parametrize("verb", ["validate", "calibrate"])
def test_one_file_listed_twice_for_one_role_is_refused_where_samples_are_pooled(exp, tmp_path, verb):
    # Listed twice with the same role, the plunge's samples would count twice: twice the
    # weight in a fit (intervals too narrow, by up to √2) and in pooled metrics, and no
    # overlap warning (a file listed again is one drilling). The commands that pool samples
    # refuse it before any replay, naming the later listing; with role "validate" the second
    # listing is fine (drill_plunge_twice). `replay` pools nothing and takes it
    # (test_replay_prints_and_stores_the_registration lists one file twice to compare two
    # registrations).
    d = tmp_path / "twice"
    manifest = drill_plunge_twice(exp, d)
    text = manifest.read_text()
    bad = d / "bad.toml"
    bad.write_text(text.replace('id = "plunge_listed_again"\npath = "plunge.h5"\nsample = "S1"\nrole = "validate"',
                                'id = "plunge_listed_again"\npath = "plunge.h5"\nsample = "S1"\nrole = "calibrate"'))
    assert bad.read_text() != text
    before = {f.name: f.read_bytes() for f in d.iterdir()}
    args = ["--params", d / "params_true.toml", "--criteria", SRC / "examples/criteria/release.toml",
            "--no-verification"] if verb == "validate" else []
    cases = [(bad.read_text(), "calibrate")]
    if verb == "validate":  # validating twice is refused the same way
        cases.append((text.replace('role = "calibrate"', 'role = "validate"', 1), "validate"))
    for manifest_text, role in cases:
        bad.write_text(manifest_text)
        before["bad.toml"] = bad.read_bytes()
        p = run(verb, bad, *args, "--out", tmp_path / "out", check=False)
        assert_refused(p.returncode, p.stderr, bad, 'recordings[4] ("plunge_listed_again")',
                       f'used to {role} by one listing at most: recordings[0] ("plunge") already does',
                       f"samples used to {role} by both", label=role)
        assert not (tmp_path / "out").exists()
        assert {f.name: f.read_bytes() for f in d.iterdir()} == before
    p = run("replay", bad, "--params", d / "params_true.toml", "--out", tmp_path / "p.h5")
    with h5py.File(tmp_path / "p.h5", "r") as f:
        t = f["recordings/plunge/t_s"][()]
    # Twice over a segment only: the line counts the samples both use, and its span, as the
    # replay's time base does (bounds off the 1 ms grid, so no sample sits on one).
    lo, hi = 1.0005, 2.0005
    both = t[(t >= lo) & (t <= hi)]
    assert 900 < both.size < t.size
    bad.write_text(cases[0][0] + f"  [[recordings.segments]]\n  start_s = {lo}\n  end_s = {hi}\n")
    p = run(verb, bad, *args, "--out", tmp_path / "out", check=False)
    assert_refused(p.returncode, p.stderr, bad, 'recordings[4] ("plunge_listed_again")',
                   f"got {both.size} samples used to calibrate by both, t = {both[0]:.6g} … {both[-1]:.6g} s",
                   label="segment")


def test_replay_names_two_recordings_that_drilled_one_spot(exp, tmp_path):
    # Each recording is replayed from the sample as scanned: the plunge's file copied and
    # listed as a second recording was predicted against bone the first had removed. The
    # replay still writes its prediction (each recording's is right for a fresh spot) but
    # warns once, naming the pair; plunge.h5 listed once more is one drilling, no pair.
    manifest = drill_plunge_twice(exp, tmp_path / "twice")
    out = tmp_path / "p.h5"
    p = run("replay", manifest, "--params", manifest.parent / "params_true.toml", "--out", out)
    warned = [l for l in p.stderr.splitlines() if "removed the same bone" in l]
    assert len(warned) == 1 and warned[0].startswith("warning: " + PLUNGE_TWICE_WARNING), p.stderr
    assert "100 % of the smaller removal" in warned[0], warned
    with h5py.File(out, "r") as f:
        recs = f["recordings"]
        assert sorted(recs) == sorted(["plunge", "plunge_again", "plunge_listed_again", "sweep", "polish"])
        # The copy replays as the original does: same file contents, same prediction.
        assert np.array_equal(recs["plunge"]["force_sensor_pred_N"][()], recs["plunge_again"]["force_sensor_pred_N"][()])
    # Without erosion nothing is removed, and the shipped example drills separate spots.
    p = run("replay", manifest, "--params", manifest.parent / "params_true.toml", "--out", tmp_path / "q.h5",
            "--no-erosion")
    assert "removed the same bone" not in p.stderr, p.stderr
    p = run("replay", exp / "experiment.toml", "--params", exp / "params_true.toml", "--out", tmp_path / "r.h5")
    assert "removed the same bone" not in p.stderr, p.stderr


def test_replay_refuses_one_file_for_both_outputs(exp, tmp_path):
    # `--out X --csv X` would write the CSV over the prediction file: refused before the
    # replay, nothing written.
    out = tmp_path / "p.h5"
    p = run("replay", "--experiment", exp / "experiment.toml", "--params", exp / "params_true.toml", "--out", out,
            "--csv", tmp_path / "." / "p.h5", check=False)
    assert p.returncode == 2, p.stdout + p.stderr
    lines = [l for l in p.stderr.splitlines() if l.strip()]
    assert len(lines) == 1 and "--csv" in lines[0] and "--out" in lines[0], p.stderr
    assert not out.exists()


def test_a_file_size_limit_fails_loudly_and_leaves_nothing_half_written(exp, tmp_path):
    # Issue 12: under a full disk `replay --csv` exited 0 with the CSV cut mid-row. With
    # RLIMIT_FSIZE (a full disk without a mount) the command must fail naming the file, and
    # neither output may exist, whole or in part; no temporary is left.
    out, csv = tmp_path / "p.h5", tmp_path / "p.csv"
    p = run_with_file_size_limit(["replay", "--experiment", exp / "experiment.toml", "--params",
                                  exp / "params_true.toml", "--out", out, "--csv", csv], 64 << 10)
    assert p.returncode == 3, p.stdout + p.stderr
    lines = burrbench_lines(p.stderr)
    assert len(lines) == 1 and ("p.csv" in lines[0] or "p.h5" in lines[0]), p.stderr
    assert "(File too large)" in lines[0], "the system's reason, from HDF5's error stack too"
    assert sorted(x.name for x in tmp_path.iterdir()) == [], list(tmp_path.iterdir())


def test_a_failure_on_the_csv_leaves_no_prediction_either(exp, tmp_path):
    # `replay --out --csv` used to keep the finished .h5 when the CSV then failed: the
    # command's outputs appear together or not at all. A file-size limit between the two
    # files' sizes lets the .h5 be written and fails the CSV.
    whole = tmp_path / "whole"
    whole.mkdir()
    args = ["replay", "--experiment", exp / "experiment.toml", "--params", exp / "params_true.toml"]
    run(*args, "--out", whole / "p.h5", "--csv", whole / "p.csv")
    h5, csv = (whole / "p.h5").stat().st_size, (whole / "p.csv").stat().st_size
    assert csv > h5 * 1.5, (h5, csv)  # else the limit below cannot split them
    limit = (h5 + csv) // 2
    failing = tmp_path / "failing"
    failing.mkdir()
    p = run_with_file_size_limit([*args, "--out", failing / "p.h5", "--csv", failing / "p.csv"], limit)
    assert p.returncode == 3, p.stdout + p.stderr
    lines = burrbench_lines(p.stderr)
    assert len(lines) == 1 and f"{failing / 'p.csv'}: write failed" in lines[0], p.stderr
    assert ".staged" not in lines[0], "the line names the user's file, not the hidden one"
    assert list(failing.iterdir()) == [], "no .h5 without its CSV, nothing hidden left"

    # With --overwrite over an earlier pair, a failure leaves both earlier files as they were.
    run(*args, "--out", failing / "p.h5", "--csv", failing / "p.csv", "--no-erosion")
    before = {f.name: f.read_bytes() for f in failing.iterdir()}
    p = run_with_file_size_limit([*args, "--out", failing / "p.h5", "--csv", failing / "p.csv", "--overwrite"], limit)
    assert p.returncode == 3, p.stdout + p.stderr
    assert {f.name: f.read_bytes() for f in failing.iterdir()} == before


def test_replay_checks_its_outputs_before_replaying(exp, tmp_path):
    # Issue 12: an unwritable output was found only after the whole replay.
    for out, csv, want in ((tmp_path / "no" / "p.h5", None, "no folder"),
                           (tmp_path, None, "names a folder"),
                           (tmp_path / "p.h5", tmp_path / "missing" / "p.csv", "--csv")):
        args = ["replay", "--experiment", exp / "experiment.toml", "--params", exp / "params_true.toml", "--out", out]
        if csv:
            args += ["--csv", csv]
        p = run(*args, check=False)
        assert p.returncode == 2 and want in p.stderr, p.stderr
        assert "replay plunge" not in p.stderr, "refused before any replay"


def test_a_constant_spindle_speed_in_the_manifest_replaces_a_missing_channel(exp, tmp_path):
    # Issue 12: a recording without spindle_rpm imported, then could not be replayed. The
    # manifest's `spindle_rpm` gives a constant speed: the same forces as the channel that
    # held that constant (30000 rpm in the synthetic recordings).
    import shutil
    for f in ("sample.h5", "plunge.h5", "params_true.toml"):
        shutil.copy(exp / f, tmp_path / f)
    with h5py.File(tmp_path / "plunge.h5", "r") as f:
        assert set(np.unique(f["streams/spindle/channels/spindle_rpm"][()])) == {30000.0}
    shutil.copy(tmp_path / "plunge.h5", tmp_path / "nospin.h5")
    with h5py.File(tmp_path / "nospin.h5", "r+") as f:
        del f["streams/spindle/channels/spindle_rpm"]
    text = (exp / "experiment.toml").read_text()
    head = text[:text.index("[[recordings]]")]
    rec = text[text.index("[[recordings]]"):text.index("[[recordings]]", text.index("[[recordings]]") + 1)]
    (tmp_path / "with.toml").write_text(head + rec)
    (tmp_path / "without.toml").write_text(head + rec.replace('path = "plunge.h5"', 'path = "nospin.h5"'))
    (tmp_path / "constant.toml").write_text(
        head + rec.replace('path = "plunge.h5"', 'path = "nospin.h5"').replace("lag_ms = 0.0", "lag_ms = 0.0\nspindle_rpm = 30000"))
    (tmp_path / "both.toml").write_text(head + rec.replace("lag_ms = 0.0", "lag_ms = 0.0\nspindle_rpm = 30000"))

    def replay(manifest, out):
        return run("replay", tmp_path / manifest, "--params", tmp_path / "params_true.toml", "--out", tmp_path / out,
                   check=False)
    p = replay("without.toml", "a.h5")
    assert_refused(p.returncode, p.stderr, tmp_path / "nospin.h5", "spindle_rpm = RPM")
    p = replay("both.toml", "b.h5")
    assert_refused(p.returncode, p.stderr, tmp_path / "both.toml", "recordings.plunge.spindle_rpm")
    assert replay("with.toml", "with.h5").returncode == 0
    assert replay("constant.toml", "const.h5").returncode == 0
    def predicted(path):
        with h5py.File(path, "r") as f:
            return f["recordings/plunge/force_sensor_pred_N"][()]
    a, b = predicted(tmp_path / "with.h5"), predicted(tmp_path / "const.h5")
    assert np.abs(a).max() > 0.2
    np.testing.assert_array_equal(a, b)


def test_a_burr_radius_contradicting_the_recording_is_refused_unless_waived(exp, tmp_path):
    # Issue 12: the recording logs the burr radius; a manifest with another one replayed
    # a different burr without a word.
    text = (exp / "experiment.toml").read_text().replace("radius_mm = 1.0", "radius_mm = 1.2")
    m = exp / "radius12.toml"
    m.write_text(text)
    p = run("replay", m, "--params", exp / "params_true.toml", "--out", tmp_path / "p.h5", check=False)
    assert_refused(p.returncode, p.stderr, m)
    assert f"burrbench: {m}: burr.radius_mm: expected the burr radius recorded in" in p.stderr, p.stderr
    assert "(/meta/burr_radius_mm = 1 mm)" in p.stderr and "got 1.2 mm" in p.stderr, p.stderr
    assert not (tmp_path / "p.h5").exists()
    # Waived for every recording: the manifest's radius is used.
    m.write_text(text.replace('lag_ms = 0.0\n', 'lag_ms = 0.0\nwaive = ["burr_radius_mm"]\n'))
    p = run("replay", m, "--params", exp / "params_true.toml", "--out", tmp_path / "p.h5", check=False)
    assert p.returncode == 0, p.stderr
    m.write_text(text.replace('lag_ms = 0.0\n', 'lag_ms = 0.0\nwaive = ["colour"]\n'))
    p = run("replay", m, "--params", exp / "params_true.toml", "--out", tmp_path / "q.h5", check=False)
    assert_refused(p.returncode, p.stderr, m, "waive", "colour")


@pytest.mark.parametrize("key,old,new,field,waive", [
    ("axis", "shaft_axis_rig = [0.8, 0.0, 0.6]", "shaft_axis_rig = [0.6, 0.0, 0.8]", "burr.shaft_axis_rig", "burr_axis_rig"),
    ("spin", "spin_sign = 1", "spin_sign = -1", "burr.spin_sign", "spin_sign")])
def test_a_burr_axis_or_spin_contradicting_the_recording_is_refused_unless_waived(exp, tmp_path, key, old, new,
                                                                                   field, waive):
    # Issue 12: synth states the axis and spin it drilled with (recording 1.1); a manifest
    # with another axis or spin replays another burr: refused naming both, unless waived.
    text = (exp / "experiment.toml").read_text()
    assert old in text
    m = tmp_path / f"{key}.toml"
    m.write_text(text.replace(old, new).replace('path = "', f'path = "{exp}/'))
    p = run("replay", m, "--params", exp / "params_true.toml", "--out", tmp_path / "p.h5", check=False)
    assert_refused(p.returncode, p.stderr, m, f"{field}: expected the", "/meta/", waive)
    assert not (tmp_path / "p.h5").exists()
    m.write_text(m.read_text().replace('lag_ms = 0.0\n', f'lag_ms = 0.0\nwaive = ["{waive}"]\n'))
    p = run("replay", m, "--params", exp / "params_true.toml", "--out", tmp_path / "p.h5", check=False)
    assert p.returncode == 0, p.stderr


def test_a_recording_that_does_not_state_its_burr_is_not_compared(exp, tmp_path):
    # recording import without --burr-axis/--spin states neither: any manifest axis goes.
    csv = tmp_path / "r.csv"
    csv.write_text("t_s,x_mm,y_mm,z_mm,fx_N,fy_N,fz_N,spindle_rpm\n" +
                   "".join(f"{k * 0.001},0,0,{10 + k * 0.001},0,0,0,60000\n" for k in range(50)))
    run("recording", "import", "--csv", csv, "--out", tmp_path / "r.h5")
    with h5py.File(tmp_path / "r.h5", "r") as f:
        assert f.attrs["format_version"].decode() == "1.1"
        assert list(f["meta"].attrs["burr_axis_rig"]) == [0, 0, 0] and f["meta"].attrs["spin_sign"] == 0
    assert "axis_rig not stated, spin not stated" in run("inspect", tmp_path / "r.h5").stdout
    man = (exp / "experiment.toml").read_text().split("[[recordings]]")[0]
    man = man.replace('path = "sample.h5"', f'path = "{exp / "sample.h5"}"')
    man = man.replace("shaft_axis_rig = [0.8, 0.0, 0.6]", "shaft_axis_rig = [0.0, 0.0, 1.0]").replace(
        "spin_sign = 1", "spin_sign = -1")
    man += f'[[recordings]]\nid = "r"\npath = "{tmp_path / "r.h5"}"\nsample = "S1"\n' \
           '[recordings.registration]\nrotation = [[1,0,0],[0,1,0],[0,0,1]]\ntranslation_mm = [0,0,0]\n'
    (tmp_path / "e.toml").write_text(man)
    p = run("replay", tmp_path / "e.toml", "--params", exp / "params_true.toml", "--out", tmp_path / "p.h5",
            check=False)
    assert p.returncode == 0, p.stderr


def kabsch_rms(rig, vol):
    """Independent rigid fit (Kabsch, SVD): the RMS residual at the beads, mm."""
    rig, vol = np.asarray(rig, float), np.asarray(vol, float)
    a, b = rig - rig.mean(axis=0), vol - vol.mean(axis=0)
    u, _, vt = np.linalg.svd(a.T @ b)
    d = np.sign(np.linalg.det(vt.T @ u.T))
    r = vt.T @ np.diag([1, 1, d]) @ u.T
    res = b - a @ r.T
    return np.sqrt((res ** 2).sum(axis=1).mean()), np.sqrt((res ** 2).sum(axis=1)).max()


def test_replay_prints_and_stores_the_registration(exp, tmp_path):
    """Issue 17: a fiducial registration's RMS, largest residual and predicted TRE appear in
    replay's output and in the prediction file; a given transform stores only its method."""
    rec = tmp_path / "clean.h5"
    synth(exp, rec, protocol="sweep")
    rig = [[0, 0, 0], [20, 0, 0], [0, 20, 0], [0, 0, 20]]
    jitter = [[0.004, 0, 0], [0, -0.003, 0], [0, 0, 0.005], [-0.002, 0.002, 0]]
    vol = (np.asarray(rig, float) + jitter).tolist()
    man = (exp / "experiment.toml").read_text().split("[[recordings]]")[0]
    man = man.replace('path = "sample.h5"', f'path = "{exp / "sample.h5"}"')
    man += (f'[[recordings]]\nid = "beads"\npath = "{rec}"\nsample = "S1"\n'
            f'[recordings.registration]\nfiducials_rig_mm = {rig}\nfiducials_vol_mm = {vol}\n'
            'fiducial_error_mm = 0.005\n'
            f'[[recordings]]\nid = "given"\npath = "{rec}"\nsample = "S1"\n'
            '[recordings.registration]\nrotation = [[1,0,0],[0,1,0],[0,0,1]]\ntranslation_mm = [0,0,0]\n')
    (tmp_path / "e.toml").write_text(man)
    p = run("replay", "--experiment", tmp_path / "e.toml", "--params", exp / "params_true.toml",
            "--out", tmp_path / "p.h5")
    rms, worst = kabsch_rms(rig, vol)
    line = next(s for s in p.stdout.splitlines() if s.strip().startswith("beads:") and "fiducial" in s)
    assert f"RMS {rms:.6f} mm, largest {kabsch_rms(rig, vol)[1]:.6f} mm" in line and "TRE" in line, line
    with h5py.File(tmp_path / "p.h5", "r") as f:
        assert f.attrs["format_version"].decode() == "2.4"
        g = f["recordings/beads"].attrs
        assert g["registration_method"].decode() == "fiducials"
        assert g["registration_rms_mm"] == pytest.approx(rms, rel=1e-9)
        assert g["registration_max_mm"] == pytest.approx(worst, rel=1e-9)
        assert g["fiducial_error_mm"] == 0.005
        # Fitzpatrick: TRE ≥ FLE/√N anywhere, and small for a path inside the beads' spread
        assert 0.005 / 2 <= g["tre_path_rms_mm"] <= g["tre_path_max_mm"] < 0.05
        h = f["recordings/given"].attrs
        assert h["registration_method"].decode() == "vol_from_rig"
        assert "registration_rms_mm" not in h and "tre_path_rms_mm" not in h


def test_a_step_the_replay_refuses_is_named_as_the_option_typed(exp, tmp_path):
    """synth takes --step-us in µs; the replay's own limit (10⁹ internal steps) and a
    non-finite step are both reported under --step-us, never as the model's step_s in
    seconds, and nothing is written."""
    for step, fragments in (("1e-9", ("--step-us", "at most 1e9 internal steps", "1e-09 µs")),
                            ("inf", ("--step-us", "a step ≥ 0", "inf"))):
        out = tmp_path / f"r{step}.h5"
        p = run("synth", "--sample", exp / "sample.h5", "--protocol", PROTOCOLS / "plunge.toml",
                "--params", exp / "params_true.toml", "--out", out, "--truth", str(out) + ".json",
                "--step-us", step, check=False)
        assert_refused(p.returncode, p.stderr, "command line", *fragments)
        assert "step_s" not in p.stderr, p.stderr
        assert not out.exists() and not Path(str(out) + ".json").exists()
