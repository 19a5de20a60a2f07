"""A force sensor whose zero drifted during a recording (zero_drift.hpp): `calibrate`
compares the force without contact before the first contact and after the last, and
names the recording in fit.json's warnings; a steady zero gives no such warning."""
import json
import shutil

import h5py
import pytest

from synthetic import make_synthetic, resynth, run_ok, validate_warnings
from report_context import context

DRIFT = "the force without contact moved by"


@pytest.fixture(scope="module")
def fits(tmp_path_factory):
    base = make_synthetic(tmp_path_factory.mktemp("synthetic") / "exp")
    warm = base.parent / "warm"
    shutil.copytree(base, warm)
    # The plunge's sensor warms: its zero creeps by 30 mN in x over the recording (1.5 σ).
    with h5py.File(warm / "plunge.h5", "r+") as f:
        t = f["streams/ft_sensor/t_ns"][()]
        force = f["streams/ft_sensor/channels/force_N"]
        ramp = 0.03 * (t - t[0]) / (t[-1] - t[0])
        values = force[()]
        values[:, 0] += ramp
        force[...] = values
    out = {}
    for name, folder in (("steady", base), ("warm", warm)):
        run_ok("calibrate", folder / "experiment.toml", "--out", folder / "cal", "--starts", 2, "--no-profiles",
               "--no-cross-validation", "--no-discretization-check")
        out[name] = json.loads((folder / "cal" / "fit.json").read_text())["settings"]["warnings"]
    out["warm_folder"] = warm
    return out


def test_a_steady_zero_says_nothing(fits):
    assert not [w for w in fits["steady"] if DRIFT in w], fits["steady"]


def test_a_drifting_zero_is_named_with_its_shift(fits):
    said = [w for w in fits["warm"] if DRIFT in w]
    assert len(said) == 1, fits["warm"]
    assert said[0].startswith("Recording plunge: " + DRIFT + " ("), said
    # The shift in x: the ramp's rise between the stretches' mean times (about 0.02 N).
    shift_x = float(said[0].split("(")[1].split(",")[0])
    assert 0.012 < shift_x < 0.03, said


def test_validate_and_the_report_say_it_too(fits):
    # The tare is one number per recording as well: the release gate names the drift on
    # stderr and among its analysis's limitations, as the analysis of the calibration does.
    warm = fits["warm_folder"]
    _, said = validate_warnings(warm / "experiment.toml", warm / "gate", DRIFT)
    assert len(said) == 1 and said[0].startswith("Recording plunge: " + DRIFT), said
    # The calibration's analysis replays at the fitted constants: its first and last
    # contacts, and so its figures, may differ by a sample.
    limits = context(warm / "cal")["findings"]
    named = [w for w in limits if DRIFT in w]
    assert len(named) == 1 and named[0].startswith("Recording plunge: " + DRIFT), limits


MOMENT_DRIFT = "the moment without contact moved by"
TORQUE = ["--torque-noise-Nmm", "0.05", "--torque-bias-Nmm", "0.5,-0.2,1.0"]


@pytest.fixture(scope="module")
def moments(tmp_path_factory):
    # The synthetic example re-made with the sensor's moment channel (as
    # test_channels_cli.py), then a copy whose plunge's moment zero creeps by 0.1 N·mm in y
    # (2 σ) over the recording while its force stays steady.
    steady = tmp_path_factory.mktemp("moments") / "steady"
    make_synthetic(steady)
    for name in ("plunge", "sweep", "polish"):
        resynth(steady, name, *TORQUE)
    text = (steady / "experiment.toml").read_text()
    (steady / "experiment.toml").write_text(
        text.replace('seed = 1\n', 'seed = 1\nchannels = ["force", "torque"]\n', 1))
    warm = steady.parent / "warm"
    shutil.copytree(steady, warm)
    with h5py.File(warm / "plunge.h5", "r+") as f:
        t = f["streams/ft_sensor/t_ns"][()]
        moment = f["streams/ft_sensor/channels/torque_Nmm"]
        values = moment[()]
        values[:, 1] += 0.1 * (t - t[0]) / (t[-1] - t[0])
        moment[...] = values
    run_ok("calibrate", warm / "experiment.toml", "--out", warm / "cal", "--starts", 2, "--no-profiles",
           "--no-cross-validation", "--no-discretization-check")
    return {"steady": steady, "warm": warm,
            "warnings": json.loads((warm / "cal" / "fit.json").read_text())["settings"]["warnings"]}


def test_a_drifting_moment_zero_is_named_by_calibrate(moments):
    said = [w for w in moments["warnings"] if MOMENT_DRIFT in w]
    assert len(said) == 1 and said[0].startswith("Recording plunge: " + MOMENT_DRIFT + " ("), moments["warnings"]
    assert ") N·mm (" in said[0], said
    # The shift in y: the ramp's rise between the stretches' mean times (about 0.07 N·mm).
    shift_y = float(said[0].split("(")[1].split(",")[1])
    assert 0.04 < shift_y < 0.1, said
    # Its force stayed steady: nothing is said about it.
    assert not [w for w in moments["warnings"] if DRIFT in w], moments["warnings"]


def test_validate_names_a_drifting_moment_zero_and_not_a_steady_one(moments):
    assert validate_warnings(moments["steady"] / "experiment.toml", moments["steady"] / "gate", MOMENT_DRIFT)[1] == []
    _, said = validate_warnings(moments["warm"] / "experiment.toml", moments["warm"] / "gate", MOMENT_DRIFT)
    assert len(said) == 1 and said[0].startswith("Recording plunge: " + MOMENT_DRIFT), said
