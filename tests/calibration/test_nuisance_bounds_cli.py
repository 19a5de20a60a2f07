"""A lag beyond its bounds (parameters.hpp nuisances_at_bounds): the synthetic experiment
with its sweep's force 35 ms late, calibrated with the default lag bounds (±20 ms), ends
with the lag at 20 ms and constants fitted against a misaligned path; calibrate names it
in its summary and fit.json's warnings. With the bounds widened it recovers the lag and
says nothing."""
import pytest
from synthetic import make_synthetic, quick_fit, resynth

SAID = "Recording sweep: the fitted lag ended at its upper bound (20 ms; [fit.nuisance] lag_bounds_ms = [-20, 20])"


@pytest.fixture(scope="module")
def late(tmp_path_factory):
    d = make_synthetic(tmp_path_factory.mktemp("lag") / "exp")
    resynth(d, "sweep", lag_ms=35)
    text = (d / "experiment.toml").read_text()
    assert "lag_bounds_ms = [-20.0, 20.0]" in text
    (d / "wide.toml").write_text(text.replace("lag_bounds_ms = [-20.0, 20.0]", "lag_bounds_ms = [-50.0, 50.0]"))
    return d


def calibrate(manifest, out):
    stdout, fit = quick_fit(manifest, out)
    lag = {n["recording_id"]: n["estimate"] for n in fit["nuisance"] if n["name"] == "lag"}
    return stdout, fit["settings"]["warnings"], lag, fit


def held_by_the_lag(fit):
    """The compact constants held because the sweep's lag at its bound moves them."""
    return {p["name"] for p in fit["parameters"] if p["class_name"] == "compact" and not p["identifiable"]
            and p["reason"].startswith("moves with sweep.lag (at its upper bound: see the warnings)")
            and p["reason"].endswith("widen [fit.nuisance] lag_bounds_ms")}


def test_a_lag_at_its_bound_is_named(late):
    stdout, warnings, lag, fit = calibrate(late / "experiment.toml", late / "cal")
    assert lag["sweep"] == pytest.approx(20, abs=0.02)
    # C1 (15.98 ± 0.26 %, fitted against a lag held 15 ms short) moves with the lag by more
    # than its interval: it is held with it, not given as a confident value.
    assert "c1" in held_by_the_lag(fit), fit["parameters"]
    said = [w for w in warnings if w.startswith(SAID)]
    assert len(said) == 1, warnings
    assert "warning: " + said[0] in stdout
    # The summary's nuisance lines mark the sweep's lag, and only it.
    marked = [line.split()[:2] for line in stdout.splitlines() if "(at its bound" in line]
    assert marked == [["sweep", "lag"]], stdout


def test_widened_bounds_recover_the_lag_and_say_nothing(late):
    stdout, warnings, lag, fit = calibrate(late / "wide.toml", late / "calw")
    assert lag["sweep"] == pytest.approx(35, abs=1)
    assert not held_by_the_lag(fit)
    assert not [w for w in warnings if "ended at its" in w], warnings
    assert "(at its bound" not in stdout
