"""The command line a user types: every mistake is one line starting `burrbench:`, exit 2,
and a typo gets the nearest verb or option (issue 12)."""
import os
import subprocess

import pytest

BURRBENCH = os.environ["BURRBENCH"]


def run(*args):
    return subprocess.run([BURRBENCH, *args], capture_output=True, text=True, timeout=60)


@pytest.mark.parametrize("args,want", [
    (["calibrat"], "burrbench: unknown command 'calibrat' (did you mean calibrate?)"),
    (["calibrate", "--experment", "E.toml", "--out", "x"],
     "burrbench: calibrate: unknown option --experment (did you mean --experiment?)"),
    (["rig", "chek"], "burrbench: rig: unknown command 'chek' (did you mean check?)"),
    (["validate", "--param", "p.toml"], "burrbench: validate: unknown option --param (did you mean --params?)"),
    (["calibrate"], "burrbench: calibrate: --experiment is required"),
    ([], "burrbench: A subcommand is required"),
])
def test_mistakes_are_one_prefixed_line_with_a_suggestion(args, want):
    p = run(*args)
    assert p.returncode == 2, p.stdout + p.stderr
    assert p.stderr.startswith(want), p.stderr
    assert p.stderr.count("\n") == 1, p.stderr


def test_unrelated_words_get_no_suggestion():
    p = run("frobnicate")
    assert p.returncode == 2 and "unknown command 'frobnicate'" in p.stderr and "did you mean" not in p.stderr


@pytest.mark.parametrize("verb", ["calibrate", "validate", "replay"])
def test_the_experiment_may_be_given_without_its_option(tmp_path, verb):
    # `burrbench calibrate E.toml`, the form the provenance example in docs/formats.md shows.
    missing = str(tmp_path / "E.toml")
    params = {"calibrate": [], "replay": ["--params", missing],
              "validate": ["--params", missing, "--criteria", missing]}[verb]  # missing too: any error names it
    p = run(verb, missing, "--out", str(tmp_path / "out"), *params)
    assert p.returncode == 2, p.stdout + p.stderr
    assert p.stderr.startswith(f"burrbench: {missing}:"), p.stderr  # taken as the experiment


def test_help_still_exits_0():
    p = run("calibrate", "--help")
    assert p.returncode == 0 and "EXPERIMENT" in p.stdout


def test_ctrl_c_leaves_no_empty_output_folder_and_a_busy_folder_is_refused(tmp_path):
    # Issue 12: Ctrl-C during a calibration left an empty output folder and no message;
    # two runs into one folder mixed their files.
    import signal
    import time
    from pathlib import Path
    src = Path(os.environ["BURRBENCH_SOURCE_DIR"]) / "examples" / "experiments" / "synthetic"
    subprocess.run(["sh", str(src / "make.sh"), BURRBENCH, str(tmp_path / "exp")], check=True,
                   capture_output=True, timeout=300)
    out = tmp_path / "fit"
    p = subprocess.Popen([BURRBENCH, "calibrate", str(tmp_path / "exp" / "experiment.toml"), "--out", str(out)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    for _ in range(100):  # until the folder exists: the fit is under way
        if out.exists():
            break
        time.sleep(0.05)
    assert out.exists()
    # A second run into the same folder is refused while the first writes it (it would mix
    # their files): exit 2, one line, the first run undisturbed.
    second = subprocess.run([BURRBENCH, "calibrate", str(tmp_path / "exp" / "experiment.toml"), "--out", str(out)],
                            capture_output=True, text=True, timeout=60)
    assert second.returncode == 2, second.stderr
    assert second.stderr == f"burrbench: {out}: --out: expected a folder no other burrbench command is writing, got in use by another run\n"
    assert p.poll() is None
    time.sleep(0.5)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    assert p.returncode == -signal.SIGINT, err
    assert "burrbench: interrupted; unfinished files removed" in err, err
    assert not out.exists()
    assert sorted(os.listdir(tmp_path)) == ["exp"], "no staging folder or temporary left behind"
