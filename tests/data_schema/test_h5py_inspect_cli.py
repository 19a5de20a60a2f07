"""`burrbench inspect` on bad TOML/JSON files: exit code 2, one line naming file, key and
expectation, input bytes untouched."""
import json

import pytest

from formats_helpers import assert_rejected, run, write_fixtures


@pytest.fixture(scope="module")
def fx(tmp_path_factory):
    return write_fixtures(tmp_path_factory.mktemp("fixtures"))


def variant(fx, name, new_name, old, new):
    text = (fx / name).read_text()
    assert old in text, old
    p = fx / new_name
    p.write_text(text.replace(old, new, 1))
    return p


def test_manifest_errors(fx):
    rot = "rotation = [ [ 1.0, 0.0, 0.0 ], [ 0.0, 1.0, 0.0 ], [ 0.0, 0.0, 1.0 ] ]"
    assert_rejected(variant(fx, "experiment.toml", "E1.toml", rot,
                            "rotation = [ [ 0.0, 1.0, 0.0 ], [ 1.0, 0.0, 0.0 ], [ 0.0, 0.0, 1.0 ] ]"),
                    "E1.toml: recordings[0].registration.rotation: expected a proper rotation (orthonormal, det +1)")
    assert_rejected(variant(fx, "experiment.toml", "E2.toml", "path = 'recording.h5'", "path = 'gone.h5'"),
                    "E2.toml: recordings[0].path: expected an existing file")
    assert_rejected(variant(fx, "experiment.toml", "E3.toml", "upper = 1000.0\n", "upper = 0.001\n"),
                    "E3.toml: fit.classes.compact.alpha: expected lower < initial < upper")
    assert_rejected(variant(fx, "experiment.toml", "E4.toml", "name = 'fixture'", "name = 'fixture'\nowner = 'x'"),
                    "E4.toml: owner: expected a known key")
    assert_rejected(variant(fx, "experiment.toml", "E5.toml", "format_version = '1.0'", "format_version = '2.1'"),
                    "E5.toml: format_version", "unknown major version")
    assert_rejected(variant(fx, "experiment.toml", "E6.toml", rot + "\n    translation_mm = [ 1.0, 2.0, 3.0 ]",
                            "fiducials_rig_mm = [[0,0,0],[1,1,1],[2,2,2]]\n"
                            "fiducials_vol_mm = [[0,0,0],[1,0,0],[0,1,0]]"),
                    "E6.toml: recordings[0].registration.fiducials_rig_mm: expected at least 3 non-collinear points")


def test_params_errors(fx):
    assert_rejected(variant(fx, "params.toml", "P1.toml", "c1_N_per_mm2 = 12.0", "c1_N_per_mm2 = -12.0"),
                    "P1.toml: classes.compact.c1_N_per_mm2: expected a finite C1 > 0 N/mm²")
    assert_rejected(variant(fx, "params.toml", "P2.toml", "mu = 0.25", "mu = 0.25\nmu_static = 0.4"),
                    "P2.toml: classes.trabecular.mu_static: expected a known key")


def test_fit_errors(fx):
    j = json.loads((fx / "fit.json").read_text())
    j["format_version"] = "7.0"
    (fx / "F1.json").write_text(json.dumps(j))
    assert_rejected(fx / "F1.json", "F1.json: format_version", "unknown major version")
    j = json.loads((fx / "fit.json").read_text())
    j["solver"]["gradient_norm"] = 1e-9
    (fx / "F2.json").write_text(json.dumps(j))
    assert_rejected(fx / "F2.json", "F2.json: solver.gradient_norm: expected a known key")
    # a number beyond double's range: not JSON a double can hold (read_fit's case is in test_formats_fit.cpp)
    (fx / "F3.json").write_text(json.dumps(j).replace('"gradient_norm": 1e-09', '"gradient_norm": 1e956349715'))
    assert_rejected(fx / "F3.json", "F3.json: <file>: expected an HDF5, TOML or JSON burrbench file")


def test_unrecognised_files(fx):
    (fx / "other.toml").write_text('format = "someone.else"\n')
    assert_rejected(fx / "other.toml", "other.toml: format: expected a burrbench format")
    (fx / "noformat.json").write_text('{"a": 1}')
    assert_rejected(fx / "noformat.json", "noformat.json: format: expected a format name string, got missing")
    (fx / "bad.toml").write_text("x = [1,\n")
    assert_rejected(fx / "bad.toml", "bad.toml", "an HDF5, TOML or JSON burrbench file")


def test_inspect_help_and_missing_argument():
    rc, out, err = run("inspect", "--help")
    assert rc == 0 and "FILE" in out
    rc, out, err = run("inspect")
    assert rc == 2
