"""`burrbench calibrate` records how its intervals treat correlated residuals
(docs/calibration.md "Uncertainty"): by default every covariance interval is widened by
√κ, κ = (1+ρ)/(1−ρ) of the residuals' lag-1 autocorrelation ρ; `--white-noise` keeps them
as for white residuals. The two runs fit the same data, so their estimates agree and their
intervals differ by exactly √κ in ln θ."""
import json
import math
import os
import subprocess
from pathlib import Path

import pytest

from synthetic import make_synthetic

BURRBENCH = os.environ["BURRBENCH"]
SRC = Path(os.environ["BURRBENCH_SOURCE_DIR"])


@pytest.fixture(scope="module")
def fits(tmp_path_factory):
    d = tmp_path_factory.mktemp("synthetic")
    make_synthetic(d)
    out = {}
    for name, extra in (("ar1", []), ("white", ["--white-noise"])):
        p = subprocess.run([BURRBENCH, "calibrate", str(d / "experiment.toml"), "--out", str(d / name),
                            "--starts", "1", "--no-profiles", "--no-cross-validation", "--threads", "1", *extra],
                           capture_output=True, text=True, timeout=600)
        assert p.returncode == 0, p.stdout + p.stderr
        out[name] = (json.loads((d / name / "fit.json").read_text()), p.stdout)
    return out


def test_fit_json_and_summary_say_how_the_intervals_treat_correlated_residuals(fits):
    fit, stdout = fits["ar1"]
    nm = fit["settings"]["noise_model"]
    rho = nm["residual_lag1"]
    assert nm["method"] == "ar1_inflation"
    assert -1 < rho < 1
    r = min(max(rho, 0.0), 0.95)
    assert nm["inflation"] == pytest.approx((1 + r) / (1 - r), rel=1e-12)
    assert nm["interval_widening"] == pytest.approx(math.sqrt(nm["inflation"]), rel=1e-12)
    assert f"residual lag-1 autocorrelation {rho:.3f}" in stdout, stdout
    white, wout = fits["white"]
    assert white["settings"]["noise_model"]["method"] == "white"
    assert white["settings"]["noise_model"]["inflation"] == 1
    assert "assume white residuals (--white-noise)" in wout, wout


def test_intervals_are_widened_by_the_square_root_of_the_inflation(fits):
    ar1, white = fits["ar1"][0], fits["white"][0]
    kappa = ar1["settings"]["noise_model"]["inflation"]
    assert kappa > 1.001  # this experiment's residuals are slightly correlated: a ratio to test
    compared = 0
    for pa, pw in zip(ar1["parameters"], white["parameters"]):
        assert (pa["class_name"], pa["name"]) == (pw["class_name"], pw["name"])
        if pa["fixed"] or not (pa["identifiable"] and pw["identifiable"]):
            continue
        assert pa["estimate"] == pytest.approx(pw["estimate"], rel=1e-9)
        ratio = math.log(pa["ci95_high"] / pa["ci95_low"]) / math.log(pw["ci95_high"] / pw["ci95_low"])
        assert ratio == pytest.approx(math.sqrt(kappa), rel=1e-6), (pa["class_name"], pa["name"])
        compared += 1
    assert compared >= 3
