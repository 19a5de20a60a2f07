"""The depth check (calibration/src/stage_depth_check.cpp): a burr 2 % larger than
[burr] radius_mm, or a registration given as exact that is 50 µm off in z, gives confident
misses (compact C1 14.63 with a 95 % interval of 14.60–14.67 against the truth 16) and, for
the radius, no other sign. After the fit the depth offsets that nothing corrects are freed
and refitted: the check names the offset, the cost it saves and the constants it moves out
of their intervals. On the experiment as made it says nothing; with the depth offset fitted
or `--no-depth-check` it does not run."""
import math

import pytest
from synthetic import fit_warnings, make_synthetic, write_variant

PREFIX = "depth check:"
TRUTH = {"alpha": 500.0, "c1": 16.0, "mu": 0.4}


@pytest.fixture(scope="module")
def exp(tmp_path_factory):
    d = make_synthetic(tmp_path_factory.mktemp("depth") / "exp")
    assert (d / "experiment.toml").read_text().count("lag_ms = 0.0\n  [recordings.registration]") == 3
    wider = (("radius_mm = 1.0\n", "radius_mm = 1.02\n"),
             ("lag_ms = 0.0\n  [recordings.registration]", 'lag_ms = 0.0\nwaive = ["burr_radius_mm"]\n  [recordings.registration]'))
    write_variant(d, "wider", *wider)
    write_variant(d, "wider_depth", *wider, ("depth_offset = false", "depth_offset = true"))
    write_variant(d, "shifted", ("translation_mm = [0.0, 0.0, 0.0]", "translation_mm = [0.0, 0.0, 0.05]"))
    return d


def test_a_burr_radius_2_percent_off_is_named(exp):
    fit, said = fit_warnings(exp / "wider.toml", exp / "wider", PREFIX)
    dc = fit["settings"]["depth_check"]
    assert dc["computed"] and dc["significant"] and dc["said"], dc
    assert dc["recordings"] == ["plunge", "sweep"]
    # Over the flat surface 20 µm of radius read as 20 µm of depth along the normal, which
    # lies 53° from the shaft: 0.02/0.6 mm along it, towards the burr's back.
    for r in ("plunge", "sweep"):
        assert dc["offsets_mm"][r] == pytest.approx(-0.02 / 0.6, abs=0.004), dc
    assert dc["cost"] - dc["refit_cost"] > 100 * dc["threshold_cost"], dc
    # Two offsets: χ²₂'s quantile is the closed form −2·ln(1 − p), in the profile's units
    # (residual variance × the noise model's inflation).
    st = fit["settings"]
    unit = st["residual_variance"] * st["noise_model"]["inflation"]
    assert dc["threshold_cost"] == pytest.approx(0.5 * -2 * math.log(0.001) * unit, rel=1e-3), (dc, unit)
    moved = {m["name"]: m for m in dc["moved"] if m["class"] == "compact"}
    assert "c1" in moved and "mu" in moved, dc
    for name, m in moved.items():
        # Out of the interval the fit gave, and back towards the truth.
        assert not m["ci95_low"] <= m["refit_estimate"] <= m["ci95_high"], m
        assert not m["ci95_low"] <= TRUTH[name] <= m["ci95_high"], m
        assert abs(m["refit_estimate"] / TRUTH[name] - 1) < abs(m["estimate"] / TRUTH[name] - 1), m
    assert len(said) == 1, said
    assert "plunge, sweep (-0.033, -0.033 mm)" in said[0], said
    assert "compact c1 14.6" in said[0] and "[burr] radius_mm (1.02 mm)" in said[0], said
    assert "depth_offset = true" in said[0], said


def test_a_registration_50_um_off_is_named_and_the_misfit_line_leaves_it_to_the_check(exp):
    fit, said = fit_warnings(exp / "shifted.toml", exp / "shifted", PREFIX)
    dc = fit["settings"]["depth_check"]
    for r in ("plunge", "sweep"):
        assert dc["offsets_mm"][r] == pytest.approx(0.05 / 0.6, abs=0.005), dc
    assert len(said) == 1 and "compact alpha" in said[0], said
    misfit = [w for w in fit["settings"]["warnings"] if w.startswith("rms(residual/σ)")]
    assert len(misfit) == 1 and "depth_offset" not in misfit[0], misfit


def test_nothing_is_said_of_the_experiment_as_made(exp):
    fit, said = fit_warnings(exp / "experiment.toml", exp / "made", PREFIX)
    dc = fit["settings"]["depth_check"]
    assert said == [] and dc["computed"] and not dc["said"] and not dc["significant"], dc
    assert dc["cost"] - dc["refit_cost"] < dc["threshold_cost"], dc
    for r in ("plunge", "sweep"):
        assert abs(dc["offsets_mm"][r]) < 0.002, dc
    stages = [s["stage"] for s in fit["solver"]["stages"]]
    assert "depth_check" in stages


def test_a_fitted_depth_offset_leaves_nothing_to_check(exp):
    fit, said = fit_warnings(exp / "wider_depth.toml", exp / "wider_depth", PREFIX)
    assert said == [] and fit["settings"]["depth_check"] == {"computed": False}


def test_no_depth_check_skips_it(exp):
    fit, said = fit_warnings(exp / "wider.toml", exp / "wider_off", PREFIX, "--no-depth-check")
    assert said == [] and fit["settings"]["depth_check"] == {"computed": False}
