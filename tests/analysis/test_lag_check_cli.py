"""A validation recording replayed at the wrong lag (lag_check.hpp): the synthetic
experiment's polish re-made 35 ms late. `validate` with the true constants fails the
release gate's R² and, now, names the lag the force follows; with the manifest's lag_ms set
to it the line goes and the gate passes. The experiment as made says nothing."""
import shutil

import pytest
from synthetic import make_synthetic, resynth, validate_warnings

SAID = "Recording polish: its measured force follows the prediction best at a lag of "


@pytest.fixture(scope="module")
def late(tmp_path_factory):
    as_made = make_synthetic(tmp_path_factory.mktemp("late") / "as_made")
    d = as_made.parent / "exp"
    shutil.copytree(as_made, d)
    resynth(d, "polish", lag_ms=35)
    text = (d / "experiment.toml").read_text()
    polish = 'id = "polish"\npath = "polish.h5"\nsample = "S1"\nrole = "validate"\nlag_ms = 0.0\n'
    assert polish in text
    # The manifest's lags must lie within the fit's lag bounds, validate or not.
    (d / "set.toml").write_text(text.replace(polish, polish.replace("lag_ms = 0.0", "lag_ms = 35.0"))
                                .replace("lag_bounds_ms = [-20.0, 20.0]", "lag_bounds_ms = [-50.0, 50.0]"))
    return d


def gate(manifest, out):
    return validate_warnings(manifest, out, "follows the prediction best at a lag")


def test_a_validation_recording_replayed_at_the_wrong_lag_is_named(late):
    code, said = gate(late / "experiment.toml", late / "gate")
    assert code == 1  # the true constants fail the gate: R² of the held-out force
    assert len(said) == 1 and said[0].startswith(SAID + "35 ms, +35 ms from the 0 ms it was replayed at"), said


def test_its_lag_set_says_nothing_and_passes(late):
    code, said = gate(late / "set.toml", late / "gate_set")
    assert (code, said) == (0, [])


def test_the_experiment_as_made_says_nothing(late):
    # Its sweep and polish were made 2 ms late against a manifest lag of 0: too small to name.
    assert gate(late.parent / "as_made" / "experiment.toml", late / "gate_as_made")[1] == []
