"""Issue 18's mismatch: data made by the model at voxel l, calibrated on the same sample at
l/2 (every voxel split into 8: the same bone). The finer model erodes and pushes
differently, so the fit's constants move away from the truth by more than their
statistical intervals. The calibration must not report them confidently wrong: every
constant either holds the truth in its (widened) 95 % interval or is reported as limited
by discretization error, with an interval widened by that error that holds the truth
(docs/calibration.md "Discretization check")."""
import json
import math
import os
import re
from pathlib import Path

import pytest

from synthetic import make_synthetic, run_ok

BURRBENCH = os.environ["BURRBENCH"]
SRC = Path(os.environ["BURRBENCH_SOURCE_DIR"])
TRUTH = {("compact", "alpha"): 500.0, ("compact", "c1"): 16.0, ("compact", "mu"): 0.4,
         ("trabecular", "alpha"): 200.0, ("trabecular", "c1"): 6.0, ("trabecular", "mu"): 0.3}


@pytest.fixture(scope="module")
def half(tmp_path_factory):
    d = tmp_path_factory.mktemp("synthetic_half")
    make_synthetic(d)
    run_ok("sample", "resample", d / "sample.h5", "--split", "2", "--out", d / "sample_half.h5")
    text = (d / "experiment.toml").read_text()
    assert 'path = "sample.h5"' in text
    (d / "experiment_half.toml").write_text(text.replace('path = "sample.h5"', 'path = "sample_half.h5"'))
    out = run_ok("calibrate", d / "experiment_half.toml", "--out", d / "fit", "--no-cross-validation")
    return json.loads((d / "fit" / "fit.json").read_text()), out, d


def interval(p):
    lo = p["profile_ci95_low"] if p["profile_ci95_low"] is not None else p["ci95_low"]
    hi = p["profile_ci95_high"] if p["profile_ci95_high"] is not None else p["ci95_high"]
    return lo, hi


def checked_constants(fit):
    """The constants the fit speaks of: identifiable ones and those held because the optimum
    is not confirmed (a misfit far above the noise); the discretization check covers both."""
    return [p for p in fit["parameters"]
            if not p["fixed"] and (p["identifiable"] or p["verdict"] == "unconfirmed")]


def value(p):
    return p["estimate"] if p["estimate"] is not None else p["held"]


def test_no_constant_is_reported_confidently_wrong(half):
    fit, out, _ = half
    checked = limited = 0
    for p in checked_constants(fit):
        truth = TRUTH[(p["class_name"], p["name"])]
        lo, hi = interval(p)
        d = p["discretization"]
        checked += 1
        if p["identifiable"] and lo <= truth <= hi:
            continue
        # Wrong, or not called identifiable: the check must name the grid as the cause, and
        # its widened interval must hold the truth.
        assert d["limited"], (p["class_name"], p["name"], lo, hi, truth)
        assert d["ci95_low"] <= truth <= d["ci95_high"], (p["class_name"], p["name"], d, truth)
        assert f"{p['class_name']:<12} {p['name']:<5}   LIMITED by discretization error" in out, out
        # The warning quotes the move and the interval's half-width in % to two significant
        # digits: a ±0.05 % interval must not read ±0.0 %.
        m = re.search(rf"{p['class_name']} {p['name']}: the estimate moves ([-+0-9.]+) % when the voxels are "
                      r"merged .*? half its 95 % interval \(±([0-9.]+) %\)", out)
        assert m, out
        half = max(math.log(hi / value(p)), math.log(value(p) / lo))
        assert float(m.group(2)) == pytest.approx(100 * math.expm1(half), rel=0.06), m.group(0)
        assert float(m.group(1)) == pytest.approx(100 * (d["coarse_estimate"] / value(p) - 1), rel=0.06), m.group(0)
        limited += 1
    # The misfit shows in the residuals too (σ from the no-contact samples).
    assert fit["residuals_summary"]["rms_normalised"] > 1.2
    assert "limited by model error" in out, out
    assert checked == 3  # the compact constants: the recordings never reach the trabecular core
    # The mismatch is real: without the check these constants would be confidently wrong.
    assert limited >= 2, json.dumps([p.get("discretization") for p in fit["parameters"]])
    # Far above the noise (rms 1.8 here), the optimum is not confirmed: none of the wrong
    # constants is called identifiable or written unflagged to params.toml.
    for p in checked_constants(fit):
        lo, hi = interval(p)
        if not lo <= TRUTH[(p["class_name"], p["name"])] <= hi:
            assert p["verdict"] == "unconfirmed", p
    dc = fit["settings"]["discretization_check"]
    assert dc["grid_explains_the_move"] is True and dc["cost_rise_at_coarse"] < 0, dc  # the data's own grid fits better


def test_the_coarse_refit_is_at_the_datas_own_voxel_size(half):
    # Merging the split sample gives back the sample the data were made on: the coarse
    # refit recovers the truth, so the error estimate is the real mismatch.
    fit, _, _ = half
    assert fit["settings"]["discretization_check"]["computed"] is True
    assert fit["settings"]["discretization_check"]["coarse_voxel_mm"] == pytest.approx(0.1)
    assert len(checked_constants(fit)) == 3
    for p in checked_constants(fit):
        assert p["discretization"]["coarse_estimate"] == pytest.approx(TRUTH[(p["class_name"], p["name"])], rel=0.03)


def test_coarse_to_fine_reaches_the_same_optimum(half):
    # Search and first refinement at 2l, the rest at l/2: the same optimum (within the
    # profile threshold) and the same intervals, from fewer fine replays.
    fit, _, d = half
    out = run_ok("calibrate", d / "experiment_half.toml", "--out", d / "c2f", "--no-cross-validation", "--coarse-to-fine")
    c2f = json.loads((d / "c2f" / "fit.json").read_text())
    st = c2f["settings"]
    assert st["coarse_to_fine"]["used"] is True and st["coarse_to_fine"]["coarse_voxel_mm"] == pytest.approx(0.1)
    assert fit["settings"]["coarse_to_fine"]["used"] is False
    stages = [s["stage"] for s in c2f["solver"]["stages"]]
    assert "coarse_to_fine" in stages and "global_search" not in stages, stages
    assert "coarse_to_fine" in out
    assert c2f["solver"]["final_cost"] <= fit["solver"]["final_cost"] + st["profiles"]["threshold_cost"]
    for a, b in zip(fit["parameters"], c2f["parameters"]):
        if a not in checked_constants(fit):
            continue
        assert b["verdict"] == a["verdict"]
        lo, hi = interval(a)
        assert lo <= value(b) <= hi, (a["name"], value(a), value(b))
        assert b["discretization"]["limited"] == a["discretization"]["limited"]


def test_inspect_reads_the_fit_as_the_calibration_left_it(half):
    # `inspect fit.json` is how a reviewer reads a fit later: each constant's value, its
    # profile interval, the discretization limit, and for the others the value held and
    # why, as fit.json stores them (μ without the unit "1").
    fit, _, d = half
    out = run_ok("inspect", d / "fit" / "fit.json")
    g = lambda x: "—" if x is None else f"{x:.6g}"
    for p in fit["parameters"]:
        head = f"  {p['class_name']:<12} {p['name']:<5}"
        unit = "" if p["unit"] == "1" else " " + p["unit"]
        if not p["identifiable"]:
            assert any(f"{head}   {v}" in out for v in ("NOT identifiable", "AT BOUND", "UNCONFIRMED optimum")), out
            assert f"(held {g(p['held'])}{unit}): {p['reason']}\n" in out, out
            dd = p.get("discretization")
            if dd and dd["limited"]:
                assert f"{head}   LIMITED by discretization error: {g(dd['coarse_estimate'])} at twice the voxel; " \
                       f"with that error [{g(dd['ci95_low'])}, {g(dd['ci95_high'])}]" in out, out
            continue
        line = (f"{head} = {g(p['estimate'])}{unit} profile 95 % [{g(p['profile_ci95_low'])}, "
                f"{g(p['profile_ci95_high'])}]; covariance [{g(p['ci95_low'])}, {g(p['ci95_high'])}]")
        assert line in out, (line, out)
        dd = p["discretization"]
        limited = f"{head}   LIMITED by discretization error: {g(dd['coarse_estimate'])} at twice the voxel; " \
                  f"with that error [{g(dd['ci95_low'])}, {g(dd['ci95_high'])}]"
        assert (limited in out) == dd["limited"], (limited, out)
    gs = fit["settings"]["global_search"]
    assert f"global search: best optimum reached by {gs['reached_best']} of {gs['starts']} starts" in out, out
