"""A registration given and taken as exact that is 50 µm off along z (half a voxel): the fit
bends the constants to it (compact α +71 %, μ −67 % on the synthetic experiment, with
intervals that miss), and only the misfit line shows it. Without the depth check that
line names the recordings whose registration nothing corrects and points at the depth
offset; with [fit.nuisance] depth_offset = true the constants come back within intervals that hold the
truth, and no hint is given."""
import pytest
from synthetic import make_synthetic, quick_fit

TRUTH = {"alpha": 500.0, "c1": 16.0, "mu": 0.4}
HINT = "The registration of plunge, sweep is given and taken as exact, and no depth offset is fitted"


@pytest.fixture(scope="module")
def shifted(tmp_path_factory):
    d = make_synthetic(tmp_path_factory.mktemp("shifted") / "exp")
    text = (d / "experiment.toml").read_text()
    assert text.count("translation_mm = [0.0, 0.0, 0.0]") == 3 and "depth_offset = false" in text
    text = text.replace("translation_mm = [0.0, 0.0, 0.0]", "translation_mm = [0.0, 0.0, 0.05]")
    (d / "experiment.toml").write_text(text)
    (d / "depth.toml").write_text(text.replace("depth_offset = false", "depth_offset = true"))
    return d


def calibrate(manifest, out, *extra):
    return quick_fit(manifest, out, *extra)[1]


def test_the_misfit_line_points_at_the_depth_offset_without_the_depth_check(shifted):
    # With the depth check (test_depth_check_cli.py) the check says it instead, with figures.
    fit = calibrate(shifted / "experiment.toml", shifted / "cal", "--no-depth-check")
    said = [w for w in fit["settings"]["warnings"] if w.startswith("rms(residual/σ)")]
    assert len(said) == 1 and HINT in said[0], fit["settings"]["warnings"]


def test_a_fitted_depth_offset_recovers_the_constants(shifted):
    fit = calibrate(shifted / "depth.toml", shifted / "cald")
    assert not [w for w in fit["settings"]["warnings"] if "depth offset" in w], fit["settings"]["warnings"]
    tol = {"alpha": 0.10, "c1": 0.02, "mu": 0.05}
    for p in fit["parameters"]:
        if p["class_name"] == "compact":
            assert abs(p["estimate"] / TRUTH[p["name"]] - 1) < tol[p["name"]], p
            assert p["ci95_low"] <= TRUTH[p["name"]] <= p["ci95_high"], p
    # 50 µm along z is 0.05/0.6 mm along the shaft, tilted 53° from z.
    for n in fit["nuisance"]:
        if n["name"] == "depth_offset":
            assert n["estimate"] == pytest.approx(0.05 / 0.6, abs=0.005), n
