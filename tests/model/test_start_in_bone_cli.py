"""A recording that begins with the burr already in bone (model::start_in_bone): both of
its streams started after the burr had cut its way in, so the replay, starting from the
bone as scanned, predicts the forces near that hole against bone that is gone. replay,
calibrate and validate name it; a touch within one voxel, and a sensor that started late
while the stage logged the approach (the replay follows the stage from its first
sample), are not named."""
import json
import os
import subprocess
from pathlib import Path

import pytest
from synthetic import START_IN_BONE_WARNING, make_synthetic, run_ok, start_late
from report_context import context

BURRBENCH = os.environ["BURRBENCH"]
SRC = Path(os.environ["BURRBENCH_SOURCE_DIR"])
SAID = START_IN_BONE_WARNING


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    return make_synthetic(tmp_path_factory.mktemp("synthetic") / "exp")


def warnings_of(*args):
    p = subprocess.run([BURRBENCH, *map(str, args)], capture_output=True, text=True, timeout=600)
    assert p.returncode in (0, 1), p.stdout + p.stderr
    return [line[len("warning: "):] for line in p.stderr.splitlines() if line.startswith("warning: ")]


def replay_warnings(manifest, out):
    return warnings_of("replay", manifest, "--params", manifest.parent / "params_true.toml", "--out", out)


def test_a_recording_that_begins_in_bone_is_named_with_its_depth(base, tmp_path):
    manifest = start_late(base, tmp_path / "cut", 1.3)
    said = [w for w in replay_warnings(manifest, tmp_path / "p.h5") if w.startswith(SAID)]
    assert len(said) == 1, said
    # The immersion depth against the closed form: 0.5·1.3 − 0.5 = 0.15 mm below the touch
    # (the first force sample after the cut is at 1.301 s: 0.1505 mm), within the partial
    # voxels of the scanned surface.
    depth = float(said[0][len(SAID):].split(" mm")[0])
    assert abs(depth - 0.1505) < 0.01, said
    assert "(t = 0 s at the manifest's lag; one voxel or the registration's error is 0.1 mm)" in said[0], said
    # The release gate says it on stderr and among its analysis's limitations.
    gate = warnings_of("validate", manifest, "--params", manifest.parent / "params_true.toml", "--criteria",
                       SRC / "examples" / "criteria" / "release.toml", "--out", tmp_path / "gate", "--no-verification")
    assert [w for w in gate if w.startswith(SAID)] == said
    limits = context(tmp_path / "gate")["findings"]
    assert [w for w in limits if w.startswith(SAID)] == said


def test_calibrate_names_it_among_the_fits_warnings(base, tmp_path):
    manifest = start_late(base, tmp_path / "cut", 1.3)
    run_ok("calibrate", manifest, "--out", tmp_path / "cal", "--starts", 1, "--no-profiles", "--no-cross-validation",
           "--no-discretization-check")
    warnings = json.loads((tmp_path / "cal" / "fit.json").read_text())["settings"]["warnings"]
    assert len([w for w in warnings if w.startswith(SAID)]) == 1, warnings


def test_a_touch_within_a_voxel_and_the_whole_recording_say_nothing(base, tmp_path):
    assert not [w for w in replay_warnings(base / "experiment.toml", tmp_path / "a.h5") if "already" in w]
    # 1.1 s: 0.05 mm deep, half a voxel: a touch-off at the scanned surface can show that.
    touch = start_late(base, tmp_path / "touch", 1.1)
    assert not [w for w in replay_warnings(touch, tmp_path / "b.h5") if "already" in w]


def test_a_sensor_that_started_late_beside_a_logging_stage_says_nothing(base, tmp_path):
    # Only the force stream begins at 1.3 s: the replay follows the stage from its first
    # sample, above the bone (vias), so nothing was cut before its path begins.
    manifest = start_late(base, tmp_path / "sensor", 1.3, streams=("ft_sensor",))
    assert not [w for w in replay_warnings(manifest, tmp_path / "c.h5") if "already" in w]
