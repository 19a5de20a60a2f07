"""A constant bent by another's bound (uncertainty.hpp shift_along_bound): the synthetic
experiment (truth compact α 500, C1 16, μ 0.4) with compact α bounded at 300 N/mm². Before,
α at its bound came back "not seen in these data" (rule 2 compared α at its upper bound with
itself), and μ 0.248 with a profile interval of ±0.6 % that misses the truth by 38 %: a
confident miss. Now α is "at bound", and μ, which moves with it, is "conditional on a bound"
with a reason that names α, in the profile verdicts and in the covariance rules alike; the
experiment as made has no such verdict."""
import json
import subprocess
import tomllib

import pytest
from synthetic import BURRBENCH, make_synthetic, quick_fit, write_variant

NARROW = ("alpha = { initial = 300.0, lower = 10.0, upper = 5000.0 }\n  c1    = { initial = 10.0, lower = 0.1, "
          "upper = 200.0 }\n  mu    = { initial = 0.3, lower = 0.01, upper = 2.0 }\n  [fit.classes.trabecular]")


@pytest.fixture(scope="module")
def exp(tmp_path_factory):
    base = make_synthetic(tmp_path_factory.mktemp("synthetic") / "exp")
    write_variant(base, "narrow", (NARROW, NARROW.replace("initial = 300.0, lower = 10.0, upper = 5000.0",
                                                          "initial = 200.0, lower = 10.0, upper = 300.0", 1)))
    return base


def compact(fit):
    return {p["name"]: p for p in fit["parameters"] if p["class_name"] == "compact"}


def test_profiles_call_alpha_at_bound_and_mu_conditional_on_it(exp, tmp_path):
    out = tmp_path / "cal"
    p = subprocess.run([BURRBENCH, "calibrate", exp / "narrow.toml", "--out", out, "--starts", "2",
                        "--no-cross-validation", "--no-discretization-check", "--no-depth-check"],
                       capture_output=True, text=True, timeout=900)
    assert p.returncode == 0, p.stdout + p.stderr
    c = compact(json.loads((out / "fit.json").read_text()))
    assert c["alpha"]["verdict"] == "at_bound" and c["alpha"]["held"] == pytest.approx(300, rel=1e-3), c["alpha"]
    mu = c["mu"]
    # μ misses the truth far beyond its profile interval: it must not be called identifiable.
    assert mu["held"] < 0.3 and mu["profile_ci95_high"] < 0.3, mu
    assert mu["verdict"] == "conditional_on_bound" and not mu["identifiable"] and mu["estimate"] is None, mu
    assert mu["reason"].startswith("moves with compact.alpha, which ended at its upper bound (300 N/mm^2)"), mu
    assert mu["reason"].endswith("widen [fit.classes.compact] alpha"), mu
    assert "  compact      mu      CONDITIONAL on a bound (held" in p.stdout, p.stdout
    params = tomllib.loads((out / "params.toml").read_text())
    assert set(params["classes"]["compact"]["not_identifiable"]) == {"alpha", "mu"}, params["classes"]["compact"]


def test_the_covariance_rules_hold_mu_with_alpha(exp, tmp_path):
    _, fit = quick_fit(exp / "narrow.toml", tmp_path / "cal")
    c = compact(fit)
    assert c["alpha"]["reason"] == "estimate at its upper bound (300 N/mm^2)", c["alpha"]
    assert not c["mu"]["identifiable"], c["mu"]
    assert c["mu"]["reason"].startswith("moves with compact.alpha, which ended at its upper bound"), c["mu"]


def test_the_experiment_as_made_has_no_constant_held_by_a_bound(exp, tmp_path):
    _, fit = quick_fit(exp / "experiment.toml", tmp_path / "cal")
    c = compact(fit)
    assert all(p["identifiable"] for p in c.values()), c
    assert not [p for p in fit["parameters"] if p["reason"].startswith("moves with")], fit["parameters"]
