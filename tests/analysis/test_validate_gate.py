"""`burrbench validate` as a simulator CI uses it: exit 0 on a passing model, 1 on a
failing one, 2 on broken inputs (one stderr line naming the file), on a real synthetic
experiment (examples/experiments/synthetic/make.sh: burrbench sample synth + synth).
The report it writes loads in headless Chromium with its plots drawn."""
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys

import h5py
import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import browser_check  # noqa: E402
from bad_input import assert_refused
from synthetic import PLUNGE_TWICE_WARNING, drill_plunge_twice
from report_context import context

BURRBENCH = os.environ.get("BURRBENCH", "burrbench")
SRC = os.environ.get("BURRBENCH_SOURCE_DIR", os.path.join(HERE, "..", ".."))
CRITERIA = os.path.join(SRC, "examples", "criteria", "release.toml")


def run(*args):
    return subprocess.run([BURRBENCH, *args], capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def exp(tmp_path_factory):
    d = tmp_path_factory.mktemp("synthetic")
    subprocess.run(["sh", os.path.join(SRC, "examples/experiments/synthetic/make.sh"), BURRBENCH, str(d)],
                   check=True, capture_output=True, timeout=300)
    return d


def sha(path):
    return hashlib.sha256(open(path, "rb").read()).hexdigest()


def validate(exp, out, params=None, criteria=CRITERIA, experiment=None):
    return run("validate", "--experiment", str(experiment or exp / "experiment.toml"),
               "--params", str(params or exp / "params_true.toml"), "--criteria", str(criteria),
               "--out", str(out))


def test_true_parameters_pass_and_report_renders(exp, tmp_path):
    inputs = [exp / f for f in ("experiment.toml", "params_true.toml", "sample.h5", "polish.h5")]
    before = [sha(p) for p in inputs]
    out = tmp_path / "gate"
    r = validate(exp, out)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "gate: PASS" in r.stdout
    gate_stdout = r.stdout
    m = json.load(open(out / "metrics.json"))
    assert m["pass"] is True and len(m["criteria"]) == 4
    # held-out data is the "polish" recording only; the model with the truth sits at the
    # synthetic noise floor (σ = 0.02 N per axis)
    pooled = [x for x in m["rows"] if x["recording"] == "" and x["role"] == "validate"
              and x["segment"] == "all" and x["axis"] == "x"][0]
    assert 0.015 < pooled["rmse_N"] < 0.03, pooled
    for f in ("report.html", "prediction.h5", "residuals.csv", "metrics.json", "criteria.toml"):
        assert (out / f).exists(), f
    assert [sha(p) for p in inputs] == before  # inputs untouched
    # `inspect` reads every file the gate wrote, analysis's formats included (issue 12).
    for f, want in (("criteria.toml", "acceptance criteria (burrbench.criteria), 4 criteria"),
                    ("metrics.json", "release gate PASS")):
        r = run("inspect", str(out / f))
        assert r.returncode == 0 and want in r.stdout and r.stdout.endswith("valid\n"), r.stdout + r.stderr
    # ... and says what a reviewer needs from each: every check of the gate with its value,
    # every recording's role and used samples, the verification's verdict.
    r = run("inspect", str(out / "metrics.json"))
    for c in m["criteria"]:
        line = f"  {'PASS' if c['pass'] else 'FAIL'} {c['name']} [{c['axis']}] = {c['value']:.4g}\n"
        assert line in r.stdout, (line, r.stdout)
    assert "criteria fixed before the fit: not established\n" in r.stdout, r.stdout
    (out / "metrics.json").write_text('{"format": "burrbench.metrics", "format_version": "1.0"}')
    r = run("inspect", str(out / "metrics.json"))
    assert_refused(r.returncode, r.stderr, out / "metrics.json", f"{out / 'metrics.json'}: rows: expected")

    html = open(out / "report.html", encoding="utf-8").read()
    assert "http://" not in html and "https://" not in html
    assert "ACCEPTANCE CRITERIA: PASS" in html
    for version in ("Ceres Solver", "libmodbus", "OpenCV", "HDF5"):
        assert version in html
    assert sha(exp / "polish.h5") in html  # input hashes in the data section
    # Solution verification (issue 18): the convergence table and, in words, whether the
    # discretization error is below the sensor noise. At R/l = 10 it is not.
    v = context(out)["verification"]
    assert [r["id"] for r in v["recordings"]] == ["plunge", "sweep", "polish"]
    assert v["below_noise"] is False
    assert "verification: " + v["verdict"] in gate_stdout
    section = html[html.index('id="verif"'):html.index('id="data"')]
    assert "DISCRETIZATION ERROR ABOVE NOISE" in section
    assert html_escaped(v["verdict"]) in section
    for rec in v["recordings"]:
        for level in ("l/2", "2l", "dt/2"):
            assert f"<td>{rec['id']}</td><td>{level}</td>" in section, (rec["id"], level)
        assert f"<b>{rec['error_N']:.3g}</b>" in section
    # What the replays used: the part of the sample within reach of the burr, as the study says.
    (reach,) = v["reach"]
    assert reach["sample"] == "S1" and reach["replayed_dims"] != reach["dims"]
    part = "×".join(map(str, reach["replayed_dims"])) + " of its " + "×".join(map(str, reach["dims"])) + " voxels"
    assert f"S1 {part}" in section[section.index('id="verification-reach"'):]
    res = json.loads(subprocess.run([sys.executable, os.path.join(HERE, "browser_check.py"),
                                     str(out / "report.html"), str(tmp_path / "chromium")],
                                    capture_output=True, text=True, timeout=200, check=True).stdout)
    assert res["console_errors"] == []
    # overview + 3 recordings × 3 plots + 2 histograms (calibrate, validate), and the
    # synth recordings' moments and spindle load: 3 recordings × (moment, load, energy), and
    # per role the QQ and autocorrelation plots
    assert res["dom"].count('data-rendered="1"') == 25
    for kind in ("torque", "spindle", "energy"):
        assert f'id="plot-{kind}-2" data-rendered="1"' in res["dom"], kind
    assert res["coloured_fraction"] > 0.003


def html_escaped(text):
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;").replace("'", "&#39;")


def test_no_verification_skips_the_study_and_says_so(exp, tmp_path):
    out = tmp_path / "gate"
    r = run("validate", "--experiment", str(exp / "experiment.toml"), "--params", str(exp / "params_true.toml"),
            "--criteria", CRITERIA, "--out", str(out), "--no-verification")
    assert r.returncode == 0, r.stdout + r.stderr
    assert "verification" not in context(out)
    html = open(out / "report.html", encoding="utf-8").read()
    assert "Not computed in this run" in html[html.index('id="verif"'):html.index('id="data"')]


def test_two_recordings_that_drill_one_spot_are_named(exp, tmp_path):
    # Each recording is replayed from the sample as scanned, so a spot drilled twice would
    # bias the second silently. The plunge copied to a second file is a second drilling of
    # its spot: a warning and a line in the report's limitations name the pair. plunge.h5
    # listed once more (one drilling, e.g. once per role) is not a pair.
    manifest = drill_plunge_twice(exp, tmp_path / "twice")
    out = tmp_path / "gate"
    r = run("validate", "--experiment", str(manifest), "--params", str(manifest.parent / "params_true.toml"),
            "--criteria", CRITERIA, "--out", str(out), "--no-verification")
    assert r.returncode == 0, r.stdout + r.stderr
    warned = [line for line in r.stderr.splitlines() if "removed the same bone" in line]
    assert len(warned) == 1, r.stderr
    assert warned[0].startswith("warning: " + PLUNGE_TWICE_WARNING), warned
    assert "100 % of the smaller removal" in warned[0], warned
    limitations = context(out)["findings"]
    assert warned[0][len("warning: "):] in limitations
    # The shipped example drills separate spots: no pair named there.
    assert not [line for line in limitations if "removed the same bone of" in line
                and "plunge_again" not in line], limitations


def test_wrong_parameters_fail(exp, tmp_path):
    text = open(exp / "params_true.toml").read()
    # friction and contact stiffness far off: the held-out forces no longer match
    wrong = re.sub(r"c1_N_per_mm2 = [0-9.]+", "c1_N_per_mm2 = 60.0", text)
    assert wrong != text
    p = tmp_path / "wrong.toml"
    p.write_text(wrong)
    out = tmp_path / "gate"
    r = validate(exp, out, params=p)
    assert r.returncode == 1, r.stdout + r.stderr
    assert "gate: FAIL" in r.stdout
    assert json.load(open(out / "metrics.json"))["pass"] is False
    assert "ACCEPTANCE CRITERIA: FAIL" in open(out / "report.html", encoding="utf-8").read()


BAD_CRITERIA = {
    "unknown_key": 'format = "burrbench.criteria"\nformat_version = "1.0"\n[[criterion]]\n'
                   'metric = "rmse_N"\naxis = "x"\nmax = 1\ntypo = 2\n',
    "unknown_recording": 'format = "burrbench.criteria"\nformat_version = "1.0"\n[[criterion]]\n'
                         'metric = "rmse_N"\naxis = "x"\nrecording = "nope"\nmax = 1\n',
    "not_toml": "[[criterion\n",
}


@pytest.mark.parametrize("name", sorted(BAD_CRITERIA))
def test_bad_criteria_exit_2(exp, tmp_path, name):
    c = tmp_path / "c.toml"
    c.write_text(BAD_CRITERIA[name])
    r = validate(exp, tmp_path / "gate", criteria=c)
    assert r.returncode == 2, r.stdout + r.stderr
    errors = [l for l in r.stderr.splitlines() if l.startswith("burrbench:")]
    assert len(errors) == 1 and str(c) in errors[0], r.stderr
    assert not (tmp_path / "gate" / "report.html").exists()


def test_missing_and_broken_files_exit_2(exp, tmp_path):
    r = validate(exp, tmp_path / "g1", params=tmp_path / "missing.toml")
    assert_refused(r.returncode, r.stderr, tmp_path / "missing.toml")
    broken = tmp_path / "experiment.toml"
    shutil.copy(exp / "experiment.toml", broken)
    broken.write_text(open(broken).read().replace('path = "plunge.h5"', 'path = "gone.h5"'))
    r = validate(exp, tmp_path / "g2", experiment=broken)
    assert_refused(r.returncode, r.stderr, broken, "expected an existing file")
    blocker = tmp_path / "file"
    blocker.write_text("x")
    r = validate(exp, blocker)
    assert r.returncode == 2 and "--out" in r.stderr, r.stderr
    r = run("validate", "--experiment", str(exp / "experiment.toml"))  # missing options
    assert r.returncode == 2


def params_without_trabecular(exp, tmp_path):
    text = open(exp / "params_true.toml").read()
    p = tmp_path / "partial.toml"
    p.write_text(text[:text.index("[classes.trabecular]")])
    return p


def test_a_parameter_set_missing_a_class_of_the_sample_is_refused(exp, tmp_path):
    # Without constants the trabecular bone would be inert (no force) and the gate could
    # still pass: validate and replay refuse it, naming the params file and the class.
    p = params_without_trabecular(exp, tmp_path)
    for r in (validate(exp, tmp_path / "gate", params=p),
              run("replay", "--experiment", str(exp / "experiment.toml"), "--params", str(p),
                  "--out", str(tmp_path / "p.h5"))):
        assert r.returncode == 2, r.stdout + r.stderr
        errors = [l for l in r.stderr.splitlines() if l.strip()]
        assert len(errors) == 1, r.stderr
        assert str(p) in errors[0] and "id = 2 (trabecular)" in errors[0], errors[0]
        assert "PASS" not in r.stdout
    assert not (tmp_path / "gate" / "report.html").exists() and not (tmp_path / "p.h5").exists()


def test_class_names_contradicting_the_sample_are_refused(exp, tmp_path):
    text = open(exp / "params_true.toml").read()
    swapped = (text.replace("[classes.compact]", "[classes.X]").replace("[classes.trabecular]", "[classes.compact]")
               .replace("[classes.X]", "[classes.trabecular]"))
    p = tmp_path / "swapped.toml"
    p.write_text(swapped)
    r = validate(exp, tmp_path / "gate", params=p)
    assert r.returncode == 2, r.stdout + r.stderr
    assert "swapped.toml: classes.trabecular.id" in r.stderr and "gives trabecular id = 2" in r.stderr, r.stderr


def test_report_without_out_writes_inside_the_directory_not_the_current_folder(exp, tmp_path):
    gate = tmp_path / "gate"
    assert validate(exp, gate).returncode == 0
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    (cwd / "fit.json").write_text("a user's file")
    r = subprocess.run([BURRBENCH, "report", str(gate)], capture_output=True, text=True, timeout=300, cwd=cwd)
    assert r.returncode == 0, r.stderr
    assert sorted(os.listdir(cwd)) == ["fit.json"] and (cwd / "fit.json").read_text() == "a user's file"
    assert (gate / "report" / "report.html").exists() and (gate / "report" / "metrics.json").exists()


def masked(text):
    """A report's text without the times it was generated at (the rest is its content)."""
    return re.sub(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ", "T", text)


def report_without_the_data(exp, folder, out):
    """`burrbench report folder` before and with the sample and the recordings moved away:
    the report reads prediction.h5, fit.json and criteria.toml alone, so both are the same."""
    r = run("report", str(folder), "--out", str(out))
    assert r.returncode == 0, r.stdout + r.stderr
    before = {f: masked((out.parent / f).read_text()) for f in (out.name, "residuals.csv", "metrics.json")}
    moved = [exp / f for f in ("sample.h5", "plunge.h5", "sweep.h5", "polish.h5")]
    try:
        for f in moved:
            f.rename(f.with_suffix(".away"))
        shutil.rmtree(out.parent)  # the same command again: the report names its command line
        r = run("report", str(folder), "--out", str(out))
    finally:
        for f in moved:
            f.with_suffix(".away").rename(f)
    assert r.returncode == 0, r.stdout + r.stderr
    for f, text in before.items():
        assert masked((out.parent / f).read_text()) == text, f
    return before[out.name]


def test_report_of_a_validate_directory_needs_neither_sample_nor_recordings(exp, tmp_path):
    gate = tmp_path / "gate"
    assert validate(exp, gate).returncode == 0
    html = report_without_the_data(exp, gate, tmp_path / "rep" / "report.html")
    assert "ACCEPTANCE CRITERIA: PASS" in html and "DISCRETIZATION ERROR" in html
    # validate wrote its report from the same inputs, in memory.
    assert masked((gate / "report.html").read_text()).split('id="repro"')[0] == html.split('id="repro"')[0]


def test_report_of_a_calibrate_directory(exp, tmp_path):
    """`burrbench report` on calibrate's output renders the prediction calibrate wrote at
    the optimum (fitted constants and nuisances) with its context: it needs neither the
    sample nor the recordings, and reports the fit's intervals, identifiability and
    correlations."""
    cal = tmp_path / "cal"
    r = run("calibrate", "--experiment", str(exp / "experiment.toml"), "--out", str(cal),
            "--no-cross-validation", "--max-iterations", "10")
    assert r.returncode == 0, r.stdout + r.stderr
    assert context(cal)["made_by"] == "calibrate"
    out = tmp_path / "rep" / "report.html"
    html = report_without_the_data(exp, cal, out)
    for f in ("fit.json", "residuals.csv", "metrics.json"):
        assert (out.parent / f).exists(), f
    assert "Parameter correlation matrix" in html and "compact.c1" in html
    assert "never in contact" in html  # trabecular is not identifiable from these recordings
    m = json.load(open(out.parent / "metrics.json"))
    rows = {(x["recording"], x["axis"]): x for x in m["rows"] if x["segment"] == "all"}
    # fitted nuisances (bias, lag) on calibration recordings, tare on the held-out one:
    # all at the synthetic noise floor σ = 0.02 N
    for rec in ("plunge", "sweep", "polish"):
        assert 0.015 < rows[(rec, "x")]["rmse_N"] < 0.03, rows[(rec, "x")]
    # A directory of the older formats (fit.json and params.toml only, or analysis.json):
    # one line saying what to rerun, exit 2.
    old = tmp_path / "old"
    old.mkdir()
    for f in ("fit.json", "params.toml"):
        shutil.copy(cal / f, old / f)
    for extra in (None, "analysis.json"):
        if extra:
            (old / extra).write_text('{"format": "burrbench.analysis"}')
        r = run("report", str(old), "--out", str(tmp_path / "rep2" / "report.html"))
        assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
        assert "rerun `burrbench validate`" in r.stderr, r.stderr
