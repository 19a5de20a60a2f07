"""`burrbench calibrate` names two recordings of one sample that removed the same bone
(docs/replay.md "Checked: no two recordings removed the same bone"). The fit takes each
recording as drilled into bone as scanned, so the one drilled second biases the constants:
the summary, fit.json's warnings and the report's limitations say so, once each."""
import json
import os
import subprocess

import pytest

from synthetic import PLUNGE_TWICE_WARNING, drill_plunge_twice, make_synthetic
from report_context import context

BURRBENCH = os.environ["BURRBENCH"]
FAST = ["--starts", "1", "--no-profiles", "--no-cross-validation", "--no-discretization-check"]


@pytest.fixture(scope="module")
def exp(tmp_path_factory):
    return make_synthetic(tmp_path_factory.mktemp("synthetic"))


def calibrate(manifest, out):
    p = subprocess.run([BURRBENCH, "calibrate", str(manifest), "--out", str(out), *FAST],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stdout + p.stderr
    return p


def test_a_spot_drilled_twice_is_named_in_the_summary_fit_json_and_report(exp, tmp_path):
    manifest = drill_plunge_twice(exp, tmp_path / "twice")
    out = tmp_path / "cal"
    p = calibrate(manifest, out)
    said = [l for l in p.stdout.splitlines() if "removed the same bone" in l]
    assert len(said) == 1 and said[0].startswith("warning: " + PLUNGE_TWICE_WARNING), p.stdout
    assert "100 % of the smaller removal" in said[0]
    assert "removed the same bone" not in p.stderr, p.stderr  # said once, in the summary
    text = said[0][len("warning: "):]
    fit = json.loads((out / "fit.json").read_text())
    assert text in fit["settings"]["warnings"]
    stages = [s["stage"] for s in fit["solver"]["stages"]]
    assert stages[-1] == "overlaps", stages
    assert text in context(out)["findings"]


def test_separate_spots_give_no_warning(exp, tmp_path):
    out = tmp_path / "cal"
    p = calibrate(exp / "experiment.toml", out)
    assert "removed the same bone" not in p.stdout + p.stderr
    fit = json.loads((out / "fit.json").read_text())
    assert not [w for w in fit["settings"]["warnings"] if "removed the same bone" in w]
    assert fit["solver"]["stages"][-1]["stage"] == "overlaps"
