"""Force samples whose burr position the stage did not measure (a gap in its position
stream): replay, calibrate and validate leave them out of use and say so, naming the gap.
Stretches the force sensor was silent through while the stage moved (a gap, a late start):
the replay follows the stage's path through them (model::align_recording, docs/replay.md
"Alignment and lag")."""
import json
import os
import subprocess
from pathlib import Path

import h5py
import numpy as np
import pytest
from synthetic import STAGE_GAP_WARNING, cut_stream, drop_samples, make_synthetic, run_ok
from report_context import context

BURRBENCH = os.environ["BURRBENCH"]
SRC = Path(os.environ["BURRBENCH_SOURCE_DIR"])


@pytest.fixture(scope="module")
def exp(tmp_path_factory):
    base = make_synthetic(tmp_path_factory.mktemp("synthetic") / "exp")
    manifest, t_a, t_b = drop_samples(base, base.parent / "gap")
    return base, manifest, t_a, t_b


def warnings_of(stderr):
    return [line for line in stderr.splitlines() if line.startswith("warning: ")]


def run(*args):
    p = subprocess.run([BURRBENCH, *map(str, args)], capture_output=True, text=True, timeout=600)
    assert p.returncode in (0, 1), p.stdout + p.stderr
    return p


def test_replay_takes_the_force_samples_in_the_gap_out_of_use_and_says_so(exp, tmp_path):
    base, manifest, t_a, t_b = exp
    whole = run("replay", base / "experiment.toml", "--params", base / "params_true.toml", "--out", tmp_path / "a.h5")
    assert warnings_of(whole.stderr) == []
    gap = run("replay", manifest, "--params", manifest.parent / "params_true.toml", "--out", tmp_path / "b.h5")
    said = warnings_of(gap.stderr)
    with h5py.File(tmp_path / "a.h5") as a, h5py.File(tmp_path / "b.h5") as b:
        t = b["recordings/sweep/t_s"][()]
        inside = (t > t_a) & (t < t_b)  # the manifest's lag is 0: t − lag = t
        assert 250 < inside.sum() < 310  # 0.3 s at 1 kHz
        assert not b["recordings/sweep/use"][()][inside].any()
        assert not b["recordings/sweep/used_validate"][()][inside].any()
        # Every other sample, and every other recording, is used as before.
        np.testing.assert_array_equal(b["recordings/sweep/use"][()][~inside], a["recordings/sweep/use"][()][~inside])
        assert a["recordings/sweep/use"][()][inside].all()
        for r in ("plunge", "polish"):
            np.testing.assert_array_equal(b[f"recordings/{r}/use"][()], a[f"recordings/{r}/use"][()])
    assert len(said) == 1, gap.stderr
    assert said[0].startswith("warning: " + STAGE_GAP_WARNING + f"{inside.sum()} force samples, in 1 gap(s)"), said
    assert f"({t_b - t_a:.4g} s without a position sample)" in said[0], said
    # verify, which leaves them out of its figures too, says the same.
    checked = run("verify", manifest, "--params", manifest.parent / "params_true.toml")
    assert warnings_of(checked.stderr) == said, checked.stderr


def test_the_replay_follows_the_stage_where_the_sensor_was_silent(exp, tmp_path):
    # Half a second without force samples in each recording. The polish strokes back and
    # forth: a line from the force sample before the gap to the one after would erode the
    # bone elsewhere (its prediction after the gap moved by up to 0.076 N before 2026-11-29).
    # The replay follows the stage's path through the gap instead, so every force measured
    # is predicted as in the whole recording, without a warning.
    base, _, _, _ = exp
    folder = base.parent / "silent"
    manifest, t_a, t_b = drop_samples(base, folder, recording="polish", from_s=1.0, to_s=1.5, stream="ft_sensor")
    assert 0.49 < t_b - t_a < 0.51
    for r in ("plunge", "sweep"):
        cut_stream(folder / f"{r}.h5", "ft_sensor", 1.0, 1.5)
    whole = run("replay", base / "experiment.toml", "--params", base / "params_true.toml", "--out", tmp_path / "a.h5")
    p = run("replay", manifest, "--params", folder / "params_true.toml", "--out", tmp_path / "p.h5")
    assert warnings_of(p.stderr) == [], p.stderr
    with h5py.File(tmp_path / "a.h5") as a, h5py.File(tmp_path / "p.h5") as b:
        for r in ("plunge", "sweep", "polish"):
            ta, tb = a[f"recordings/{r}/t_s"][()], b[f"recordings/{r}/t_s"][()]
            kept = np.isin(ta, tb)
            assert kept.sum() == len(tb) and len(ta) - len(tb) > 450, r
            fa = a[f"recordings/{r}/force_sensor_pred_N"][()][kept]
            fb = b[f"recordings/{r}/force_sensor_pred_N"][()]
            assert np.abs(fa).max() > 0.1, r  # the burr cuts bone
            np.testing.assert_allclose(fb, fa, rtol=0, atol=1e-9, err_msg=r)
    # The report's data-quality table lists each silent stretch, as an event of its own.
    gate = run("validate", manifest, "--params", folder / "params_true.toml", "--criteria",
               SRC / "examples" / "criteria" / "release.toml", "--out", tmp_path / "gate", "--no-verification")
    assert warnings_of(gate.stderr) == [], gate.stderr
    for rid, rec in context(tmp_path / "gate")["recordings"].items():
        silent = [e for e in rec["quality"]["events"] if e["kind"] == "force_silent"]
        assert len(silent) == 1, rid
        assert silent[0]["t_s"] == pytest.approx(t_a) and silent[0]["stream"] == "ft_sensor", silent
        assert silent[0]["detail"].startswith(f"no force sample for {t_b - t_a:.4g} s: the replay followed"), silent


def test_the_replay_follows_the_stage_before_a_sensor_that_started_late(exp, tmp_path):
    # The polish's sensor starts 1.5 s after its stage, while the burr already cut: a replay
    # from the first force sample would cut into whole bone (its prediction moved by up to
    # 0.33 N, more than the largest force, before 2026-11-29). It follows the stage's path
    # from the stage's first sample instead.
    base, _, _, _ = exp
    folder = base.parent / "late"
    manifest, t_a, t_b = drop_samples(base, folder, recording="polish", from_s=-1.0, to_s=1.5, stream="ft_sensor")
    assert t_a is None and t_b == pytest.approx(1.5)
    whole = run("replay", base / "experiment.toml", "--params", base / "params_true.toml", "--out", tmp_path / "a.h5")
    p = run("replay", manifest, "--params", folder / "params_true.toml", "--out", tmp_path / "p.h5")
    assert warnings_of(p.stderr) == [], p.stderr
    with h5py.File(tmp_path / "a.h5") as a, h5py.File(tmp_path / "p.h5") as b:
        tb = b["recordings/polish/t_s"][()]  # from the late first sample: 0, 1 ms, ...
        fb = b["recordings/polish/force_sensor_pred_N"][()]
        fa = a["recordings/polish/force_sensor_pred_N"][()][-len(tb):]
        np.testing.assert_allclose(a["recordings/polish/t_s"][()][-len(tb):] - 1.5, tb, atol=1e-9)
        assert np.abs(fa).max() > 0.1
        np.testing.assert_allclose(fb, fa, rtol=0, atol=1e-9)


def test_calibrate_and_validate_leave_them_out_and_say_so(exp, tmp_path):
    base, manifest, t_a, t_b = exp
    out = run_ok("calibrate", manifest, "--out", tmp_path / "cal", "--starts", 2, "--no-profiles",
                 "--no-cross-validation", "--no-discretization-check")
    fit = json.loads((tmp_path / "cal" / "fit.json").read_text())
    with h5py.File(tmp_path / "cal" / "prediction.h5") as p:
        t = p["recordings/sweep/t_s"][()]
    n = int(((t > t_a) & (t < t_b)).sum())
    # The sweep calibrates: its samples in the gap are among the excluded (none else is).
    assert fit["residuals_summary"]["samples_excluded"] == n
    said = [w for w in fit["settings"]["warnings"] if w.startswith(STAGE_GAP_WARNING)]
    assert len(said) == 1 and said[0].startswith(STAGE_GAP_WARNING + f"{n} force samples"), said
    assert "warning: " + said[0] in out
    assert said[0] in context(tmp_path / "cal")["findings"]

    gate = run("validate", manifest, "--params", manifest.parent / "params_true.toml", "--criteria",
               SRC / "examples" / "criteria" / "release.toml", "--out", tmp_path / "gate", "--no-verification")
    assert ["warning: " + said[0]] == [w for w in warnings_of(gate.stderr) if STAGE_GAP_WARNING in w], gate.stderr
    assert said[0] in context(tmp_path / "gate")["findings"]
