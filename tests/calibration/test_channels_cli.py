"""Fitting the moments and the spindle's load beside the force (issue 13, [fit] channels):
the synthetic example re-made with the model's moment and spindle load (noise, a moment
bias, the drive's idle and viscous torque), calibrated with the force alone and with all
three channels. The extra channels recover the truth with intervals that hold it, and
narrow the intervals of the constants they carry (α through the spindle's energy, μ
through the friction couple); their nuisances come back too."""
import json
import os
import subprocess
from pathlib import Path

import pytest

from synthetic import make_synthetic, resynth, run_ok
from report_context import context

BURRBENCH = os.environ["BURRBENCH"]
SRC = Path(os.environ["BURRBENCH_SOURCE_DIR"])
TRUTH = {"alpha": 500.0, "c1": 16.0, "mu": 0.4}  # compact (the recordings never reach trabecular bone)
EXTRA = ["--torque-noise-Nmm", "0.05", "--torque-bias-Nmm", "0.5,-0.2,1.0", "--spindle-noise-Nmm", "0.005",
         "--spindle-idle-Nmm", "0.3", "--spindle-viscous-Nmm-per-krpm", "0.01"]


@pytest.fixture(scope="module")
def fits(tmp_path_factory):
    d = tmp_path_factory.mktemp("channels")
    make_synthetic(d)
    for name in ("plunge", "sweep", "polish"):
        resynth(d, name, *EXTRA)
    text = (d / "experiment.toml").read_text()
    (d / "all.toml").write_text(text.replace('seed = 1\n', 'seed = 1\nchannels = ["force", "torque", "spindle"]\n', 1))
    import h5py
    out = {"dir": d, "mean_krpm": {}}
    for rec in ("plunge", "sweep"):
        with h5py.File(d / f"{rec}.h5") as f:
            out["mean_krpm"][rec] = float(abs(f["streams/spindle/channels/spindle_rpm"][()]).mean()) / 1000
    for name, manifest in (("force", "experiment.toml"), ("all", "all.toml")):
        # 6 starts (the manifest asks for 2): with the spindle's load the landscape has a
        # local optimum at the bounds (α small, μ large) that one of two starts can end in.
        stdout = run_ok("calibrate", d / manifest, "--out", d / name, "--no-cross-validation", "--no-discretization-check",
                     "--starts", "6")
        out[name] = (json.loads((d / name / "fit.json").read_text()), stdout)
    return out


def compact(fit):
    return {p["name"]: p for p in fit["parameters"] if p["class_name"] == "compact"}


def test_all_channels_recover_the_truth_within_intervals_that_hold_it(fits):
    fit, stdout = fits["all"]
    ch = fit["settings"]["channels"]
    assert ch["torque"] and ch["spindle"] and "estimated" in ch["sigma_torque_source"]
    assert ch["sigma_torque_Nmm"] == pytest.approx(0.05, rel=0.15)
    # The sweep turns at two speeds, so the no-contact spindle samples hold two idle levels
    # (the viscous term): the median absorbs one, and the estimate errs high.
    assert 0.0045 < ch["sigma_spindle_Nmm"] < 0.008
    assert "channels: force, moment" in stdout and "spindle load" in stdout
    tol = {"alpha": 0.10, "c1": 0.02, "mu": 0.05}
    for name, p in compact(fit).items():
        assert p["verdict"] == "identifiable", p
        assert abs(p["estimate"] / TRUTH[name] - 1) < tol[name], (name, p["estimate"])
        assert p["profile_ci95_low"] <= TRUTH[name] <= p["profile_ci95_high"], (name, p)
    nz = {(n["recording_id"], n["name"]): n for n in fit["nuisance"]}
    for rec in ("plunge", "sweep"):
        for axis, want in zip("xyz", (0.5, -0.2, 1.0)):
            n = nz[(rec, f"torque_bias_{axis}")]
            assert abs(n["estimate"] - want) < 4 * n["std_error"] + 0.01, n
        assert nz[(rec, "spindle_idle")]["unit"] == "N*mm"
    # The idle offset is the drive's load at the recording's mean speed (0.3 + 0.01 per 1000 rpm).
    for rec in ("plunge", "sweep"):
        n = nz[(rec, "spindle_idle")]
        assert n["estimate"] == pytest.approx(0.3 + 0.01 * fits["mean_krpm"][rec], abs=0.01), n


def test_the_new_channels_narrow_the_intervals(fits):
    force, all_ = compact(fits["force"][0]), compact(fits["all"][0])
    assert fits["force"][0]["settings"]["channels"] == {"force": True, "torque": False, "spindle": False}
    widths = {}
    for name in ("alpha", "c1", "mu"):
        a, b = force[name], all_[name]
        wa = b["profile_ci95_high"] / b["profile_ci95_low"]
        wf = a["profile_ci95_high"] / a["profile_ci95_low"]
        widths[name] = (wf, wa)
    # α (the spindle's energy balance) and μ (the couple) gain most.
    assert widths["alpha"][1] < widths["alpha"][0], widths
    assert widths["mu"][1] < widths["mu"][0], widths


def test_channels_are_refused_where_they_cannot_be_fitted(fits, tmp_path):
    from bad_input import assert_refused
    d = fits["dir"]
    text = (d / "all.toml").read_text().replace('channels = ["force", "torque", "spindle"]', 'channels = ["torque"]')
    (tmp_path / "bad.toml").write_text(text.replace('path = "', f'path = "{d}/'))
    p = subprocess.run([BURRBENCH, "calibrate", str(tmp_path / "bad.toml"), "--out", str(tmp_path / "bad")],
                       capture_output=True, text=True, timeout=300)
    assert_refused(p.returncode, p.stderr, tmp_path / "bad.toml", "fit.channels", "force")
    assert not (tmp_path / "bad").exists()


def test_channel_information_agrees_with_the_two_fits(fits):
    """fit.json channel_information compares, at the all-channel optimum, the linearised
    interval from every row with the one from the force rows alone. Checked against two
    independent numbers: the all-channel fit's own covariance (Ceres) and the force-only
    fit's covariance at its own optimum."""
    all_, force = fits["all"][0], fits["force"][0]
    assert force["channel_information"] is None
    ci = all_["channel_information"]
    assert ci["channels"] == ["force", "torque", "spindle"]
    rows = {p["name"]: p for p in ci["parameters"] if p["class_name"] == "compact"}
    assert set(rows) == {"alpha", "c1", "mu"}
    for name, row in rows.items():
        a, f = compact(all_)[name], compact(force)[name]
        assert row["se_log_all"] == pytest.approx(a["std_error"] / a["estimate"], rel=0.02), (name, row, a)
        assert row["se_log_force"] == pytest.approx(f["std_error"] / f["estimate"], rel=0.10), (name, row, f)
        assert row["ci95_factor_force"] > row["ci95_factor_all"] > 1, row
    (corr,) = [c for c in ci["correlations"] if c["class_name"] == "compact"]
    assert corr["pair"] == "c1-alpha" and -1 <= corr["all"] <= 1 and -1 <= corr["force"] <= 1


def test_report_shows_the_moments_the_spindle_energy_and_what_the_channels_add(fits, tmp_path):
    import re
    import sys
    d = fits["dir"]
    run_ok("report", d / "all", "--out", tmp_path / "rep" / "report.html")
    rep = tmp_path / "rep"
    import h5py
    ctx = context(d / "all")
    with h5py.File(d / "all" / "prediction.h5") as f:
        recs = {rid: {"datasets": set(g), **{k: (v.decode() if isinstance(v, bytes) else v) for k, v in g.attrs.items()}}
                for rid, g in f["recordings"].items()}
    assert all({"torque_sensor_meas_Nmm", "spindle_torque_meas_Nmm", "spin_rad_s"} <= recs[r]["datasets"]
               for r in ("plunge", "sweep", "polish"))
    # Fitted recordings take the fit's idle terms; the held-out polish the tare.
    assert [recs[r]["spindle_offset_source"] for r in ("plunge", "sweep", "polish")] == ["fit", "fit", "tare"]
    # Energy balance through the prediction: α·removed equals the replay's friction work, and
    # the drive's measured cutting energy equals the predicted one (noise ≈ 0.005 N·mm).
    (compact_,) = [c for c in ctx["parameters"] if c["class_name"] == "compact"]
    label = compact_["class_label"]
    for rid in ("plunge", "sweep", "polish"):
        removed, work = recs[rid]["removed_mm3"][label], recs[rid]["friction_energy_mJ"][label]
        assert removed > 0
        assert compact_["alpha_N_per_mm2"] * removed == pytest.approx(work, rel=1e-6)
    html = (rep / "report.html").read_text()
    sec = html[html.index('id="wrench"'):html.index('id="resid"')]
    table = sec[sec.index('id="energy-table"'):sec.index("</table>", sec.index('id="energy-table"'))]
    ratios = [float(x) for x in re.findall(r"<td class=\"num\"><b>([0-9.]+)</b></td></tr>", table)]
    assert len(ratios) == 3 and all(abs(r - 1) < 0.05 for r in ratios), ratios
    chan = sec[sec.index('id="channel-table"'):]
    assert "correlation C1–α" in chan and chan.count("(in ln θ)") == 3
    # Rendering the calibrate directory again gives the same section.
    run_ok("report", d / "all", "--out", tmp_path / "again" / "report.html")
    again = (tmp_path / "again" / "report.html").read_text()
    assert again[again.index('id="energy-table"'):again.index('id="resid"')] == \
        html[html.index('id="energy-table"'):html.index('id="resid"')]
    # A real browser draws the moment, spindle and energy plots of every recording.
    p = subprocess.run([sys.executable if sys.executable.startswith("/usr/bin") else "/usr/bin/python3",
                        str(SRC / "tests" / "analysis" / "browser_check.py"), str(rep / "report.html"),
                        str(tmp_path / "chromium")], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
    seen = json.loads(p.stdout)
    assert seen["console_errors"] == []
    for kind in ("torque", "spindle", "energy"):
        for i in range(3):
            assert re.search(rf'id="plot-{kind}-{i}" data-rendered="1"', seen["dom"]), (kind, i)
