"""The overwrite policy, the same in every verb (issue 12, README "overwrite policy"):
no output replaces an existing file unless --overwrite; no output is ever an input, not
even with --overwrite; folder outputs (calibrate, validate, report) must be new or empty
and appear all together or not at all."""
import hashlib
import os
import shutil
import subprocess
from pathlib import Path

import pytest

from bad_input import assert_refused
from file_size_limit import burrbench_lines, run_with_file_size_limit

BURRBENCH = os.environ["BURRBENCH"]
SRC = Path(os.environ["BURRBENCH_SOURCE_DIR"])
CRITERIA = SRC / "examples" / "criteria" / "release.toml"
USERS = "a user's file\n"


def run(*args):
    return subprocess.run([BURRBENCH, *map(str, args)], capture_output=True, text=True, timeout=300)


def sha(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def exp(tmp_path_factory):
    d = tmp_path_factory.mktemp("synthetic")
    subprocess.run(["sh", str(SRC / "examples/experiments/synthetic/make.sh"), BURRBENCH, str(d)],
                   check=True, capture_output=True, timeout=300)
    return d


def users_file(path):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(USERS)
    return path


def no_leftovers(folder):
    """No staging folder or temporary of ours is left anywhere below `folder`."""
    left = [p for p in Path(folder).rglob("*")
            if any(mark in p.name for mark in (".staging-", ".staged-", ".previous-", ".tmp-"))]
    assert not left, left


@pytest.mark.parametrize("verb", ["sample synth", "synth --out", "synth --truth", "replay --out", "replay --csv",
                                  "sample export-nrrd"])
def test_no_output_replaces_an_existing_file_without_overwrite(exp, tmp_path, verb):
    e = exp / "experiment.toml"
    target = users_file(tmp_path / {"sample synth": "s.h5", "synth --out": "r.h5", "synth --truth": "t.json",
                                    "replay --out": "p.h5", "replay --csv": "p.csv",
                                    "sample export-nrrd": "x_labels.nrrd"}[verb])
    args = {
        "sample synth": ["sample", "synth", "--extent-mm", "2", "2", "1", "--voxel-mm", "0.2", "--out", target],
        "synth --out": ["synth", "--sample", exp / "sample.h5", "--protocol", SRC / "examples/protocols/plunge.toml",
                        "--params", exp / "params_true.toml", "--out", target, "--truth", tmp_path / "new.json"],
        "synth --truth": ["synth", "--sample", exp / "sample.h5", "--protocol", SRC / "examples/protocols/plunge.toml",
                          "--params", exp / "params_true.toml", "--out", tmp_path / "new.h5", "--truth", target],
        "replay --out": ["replay", e, "--params", exp / "params_true.toml", "--out", target],
        "replay --csv": ["replay", e, "--params", exp / "params_true.toml", "--out", tmp_path / "new.h5",
                         "--csv", target],
        "sample export-nrrd": ["sample", "export-nrrd", exp / "sample.h5", "--out-prefix", tmp_path / "x"],
    }[verb]
    p = run(*args)
    assert p.returncode == 2, p.stdout + p.stderr
    assert p.stderr.count("\n") == 1 and str(target) in p.stderr and "--overwrite" in p.stderr, p.stderr
    assert target.read_text() == USERS
    assert sorted(x.name for x in tmp_path.iterdir()) == [target.name], "refused before writing anything"
    p = run(*args, "--overwrite")
    assert p.returncode == 0, p.stdout + p.stderr
    assert target.read_bytes() != USERS.encode()
    no_leftovers(tmp_path)


@pytest.mark.parametrize("verb", ["sample synth", "sample resample", "sample export-nrrd", "sample import", "synth",
                                  "recover", "acquire --out", "acquire --journal", "replay", "verify"])
def test_an_output_file_in_a_missing_folder_is_refused_before_any_work(exp, tmp_path, verb):
    # One line naming the path, the option and the missing folder, exit 2, before any work
    # (a resample or a session is not run only to fail at its end with an I/O error), and
    # nothing written anywhere.
    gone = tmp_path / "no" / "such"
    (tmp_path / "rig.toml").write_text((SRC / "examples/rigs/virtual.toml").read_text())
    (tmp_path / "j.journal").write_bytes(b"")
    target, option = gone / "out.h5", "--out"
    args = {
        "sample synth": ["sample", "synth", "--out", target],
        "sample resample": ["sample", "resample", exp / "sample.h5", "--split", "2", "--out", target],
        "sample export-nrrd": ["sample", "export-nrrd", exp / "sample.h5", "--out-prefix", gone / "x"],
        "sample import": ["sample", "import", "--labels", tmp_path / "rig.toml", "--out", target],
        "synth": ["synth", "--sample", exp / "sample.h5", "--protocol", SRC / "examples/protocols/plunge.toml",
                  "--params", exp / "params_true.toml", "--out", target, "--truth", tmp_path / "t.json"],
        "recover": ["recover", tmp_path / "j.journal", "--out", target],
        "acquire --out": ["acquire", "--rig", tmp_path / "rig.toml", "--out", target, "--duration", "1"],
        "acquire --journal": ["acquire", "--rig", tmp_path / "rig.toml", "--out", tmp_path / "r.h5",
                              "--journal", target, "--duration", "1"],
        "replay": ["replay", exp / "experiment.toml", "--params", exp / "params_true.toml", "--out", target],
        "verify": ["verify", exp / "experiment.toml", "--params", exp / "params_true.toml", "--out", target],
    }[verb]
    if verb == "sample export-nrrd":
        target, option = gone / "x_labels.nrrd", "--out-prefix"
    if verb == "acquire --journal":
        option = "--journal"
    before = sorted(p.name for p in tmp_path.iterdir())
    p = run(*args)
    assert_refused(p.returncode, p.stderr, target, f"{option}: expected a path in an existing folder", label=verb)
    assert p.stderr == f"burrbench: {target}: {option}: expected a path in an existing folder, got no folder {gone}\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == before


@pytest.mark.parametrize("verb", ["calibrate", "validate", "report"])
def test_a_folder_output_must_be_new_or_empty(exp, tmp_path, verb):
    out = tmp_path / "out"
    mine = users_file(out / "notes.txt")
    clash = users_file(out / {"calibrate": "fit.json", "validate": "metrics.json", "report": "report.html"}[verb])
    if verb == "report":
        assert run("validate", exp / "experiment.toml", "--params", exp / "params_true.toml", "--criteria", CRITERIA,
                   "--out", tmp_path / "gate").returncode == 0
    args = {
        "calibrate": ["calibrate", exp / "experiment.toml", "--out", out, "--no-cross-validation", "--no-profiles",
                      "--starts", "1", "--max-iterations", "2"],
        "validate": ["validate", exp / "experiment.toml", "--params", exp / "params_true.toml", "--criteria",
                     CRITERIA, "--out", out],
        "report": ["report", tmp_path / "gate", "--out", out / "report.html"],
    }[verb]
    p = run(*args)
    assert p.returncode == 2, p.stdout + p.stderr
    assert p.stderr.startswith(f"burrbench: {out}: --out: expected a new or empty folder (--overwrite writes "
                               "into an existing one, replacing files of the same names), got it holds 2 entries")
    assert p.stderr.count("\n") == 1, p.stderr
    assert "calibrate" not in p.stdout and mine.read_text() == USERS and clash.read_text() == USERS
    # --overwrite: the command's files replace their namesakes, the user's other files stay.
    p = run(*args, "--overwrite")
    assert p.returncode == 0, p.stdout + p.stderr
    assert mine.read_text() == USERS and clash.read_text() != USERS
    no_leftovers(tmp_path)


def test_an_input_named_like_an_output_is_never_replaced_not_even_with_overwrite(exp, tmp_path):
    # Issue 12: a manifest called fit.json, criteria called metrics.json in the output folder.
    work = tmp_path / "exp"
    shutil.copytree(exp, work)
    shutil.copy(work / "experiment.toml", work / "fit.json")
    before = sha(work / "fit.json")
    p = run("calibrate", work / "fit.json", "--out", work, "--overwrite", "--no-cross-validation")
    assert p.returncode == 2 and p.stderr.count("\n") == 1, p.stdout + p.stderr
    assert f"{work / 'fit.json'}: --out: expected an output that is not one of the inputs" in p.stderr, p.stderr
    assert sha(work / "fit.json") == before
    out = tmp_path / "gate"
    users_file(out / "notes.txt")
    shutil.copy(CRITERIA, out / "metrics.json")
    before = sha(out / "metrics.json")
    p = run("validate", exp / "experiment.toml", "--params", exp / "params_true.toml", "--criteria",
            out / "metrics.json", "--out", out, "--overwrite")
    assert p.returncode == 2 and "is the input" in p.stderr, p.stdout + p.stderr
    assert sha(out / "metrics.json") == before and sorted(os.listdir(out)) == ["metrics.json", "notes.txt"]
    no_leftovers(tmp_path)


@pytest.mark.parametrize("name", ["params.toml", "fit.json"])
def test_calibrate_never_replaces_its_criteria_not_even_with_overwrite(exp, tmp_path, name):
    # Issue 59, N1: criteria named like one of calibrate's outputs, in its --out folder,
    # were replaced by the fitted parameter set (exit 0).
    out = tmp_path / "D"
    out.mkdir()
    shutil.copy(CRITERIA, out / name)
    before = sha(out / name)
    p = run("calibrate", exp / "experiment.toml", "--criteria", out / name, "--out", out, "--overwrite",
            "--no-cross-validation")
    assert_refused(p.returncode, p.stderr, out / name, "--out", "not one of the inputs")
    assert sha(out / name) == before and os.listdir(out) == [name]
    no_leftovers(tmp_path)


def test_outputs_appear_all_together_or_not_at_all(exp, tmp_path):
    # A criterion about a recording the experiment lacks is found only after the replay:
    # exit 2, and no output folder, no half-written files, no staging folder.
    bad = tmp_path / "criteria.toml"
    bad.write_text(CRITERIA.read_text() + '\n[[criterion]]\nname = "x"\nmetric = "r2"\naxis = "x"\n'
                   'recording = "no-such-recording"\nmin = 0.5\n')
    out = tmp_path / "gate"
    p = run("validate", exp / "experiment.toml", "--params", exp / "params_true.toml", "--criteria", bad,
            "--out", out)
    assert p.returncode == 2 and "no-such-recording" in p.stderr, p.stdout + p.stderr
    assert sorted(os.listdir(tmp_path)) == ["criteria.toml"], os.listdir(tmp_path)
    # The same into an existing folder with --overwrite: its files are as they were.
    users_file(out / "report.html")
    p = run("validate", exp / "experiment.toml", "--params", exp / "params_true.toml", "--criteria", bad,
            "--out", out, "--overwrite")
    assert p.returncode == 2, p.stdout + p.stderr
    assert sorted(os.listdir(out)) == ["report.html"] and (out / "report.html").read_text() == USERS
    # A successful run: every file at once.
    p = run("validate", exp / "experiment.toml", "--params", exp / "params_true.toml", "--criteria", CRITERIA,
            "--out", tmp_path / "ok")
    assert p.returncode == 0, p.stdout + p.stderr
    assert {"report.html", "metrics.json", "prediction.h5", "residuals.csv",
            "criteria.toml", "params.toml"} <= set(os.listdir(tmp_path / "ok"))
    no_leftovers(tmp_path)


def test_a_failed_write_into_an_output_folder_names_the_users_path(exp, tmp_path):
    # A full disk (here a file-size limit) while `validate` writes its folder: exit 3, the
    # line names the file in --out, not the hidden staging folder, and nothing is left.
    out = tmp_path / "gate"
    p = run_with_file_size_limit(["validate", exp / "experiment.toml", "--params", exp / "params_true.toml",
                                  "--criteria", CRITERIA, "--out", out, "--no-verification"], 64 << 10)
    assert p.returncode == 3, p.stdout + p.stderr
    lines = burrbench_lines(p.stderr)
    assert len(lines) == 1 and lines[0].startswith(f"burrbench: error: {out}/") and "(File too large)" in lines[0], \
        p.stderr
    assert ".staging-" not in lines[0], lines[0]
    assert os.listdir(tmp_path) == [], os.listdir(tmp_path)


def test_two_runs_writing_the_same_output_never_replace_one_another(exp, tmp_path):
    # Issue 59, N2: two `replay` runs writing the same --out/--csv without --overwrite both
    # exited 0 in 23 of 24 pairs, the later silently replacing the earlier one's files.
    # Now one writes them and the other is refused (exit 2, one line), as folders are.
    for i in range(4):
        out, csv = tmp_path / f"p{i}.h5", tmp_path / f"p{i}.csv"
        args = [BURRBENCH, "replay", str(exp / "experiment.toml"), "--params", str(exp / "params_true.toml"),
                "--out", str(out), "--csv", str(csv)]
        procs = [subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for _ in range(2)]
        done = [(p.wait(timeout=300), p.stderr.read()) for p in procs]
        codes = sorted(rc for rc, _ in done)
        assert codes == [0, 2], done
        err = next(e for rc, e in done if rc == 2)
        last = err.strip().splitlines()[-1]  # after the replay's progress lines
        assert last.startswith("burrbench: ") and ("p%d." % i) in last and "does not exist yet" in last, err
        assert out.exists() and csv.exists()
    no_leftovers(tmp_path)
