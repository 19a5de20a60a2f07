"""`burrbench study` (issue 16): a small study of 3 synthetic specimens runs through
Snakemake's local executor, a second run does nothing, deleting one specimen's fit redoes
only that specimen, and the population estimate's interval holds the known population
mean. The Slurm profile is checked by a dry run in every case."""
import json
import os
import shutil
import re
import subprocess
import sys
import time

import pytest

from bad_input import assert_refused
from synthetic import BURRBENCH, SRC

MAKE = SRC / "examples" / "study" / "make.py"
SEED = 3  # fixed: the recovery assertion below is for this draw


def study(*args, timeout=900):
    return subprocess.run([BURRBENCH, "study", *map(str, args)], capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    if shutil.which("snakemake") is None:
        pytest.fail("snakemake is not installed: scripts/install-deps installs Debian's snakemake")
    d = tmp_path_factory.mktemp("study")
    subprocess.run(["/usr/bin/python3", MAKE, BURRBENCH, d, "--specimens", "3", "--seed", str(SEED), "--starts", "2"],
                   check=True, capture_output=True, timeout=600)
    p = study("run", d / "study.toml", "--out", d / "results", "--cores", "2")
    assert p.returncode == 0, p.stdout + p.stderr
    return d


def fit_mtimes(d):
    return {s: (d / "results" / "specimens" / s / "cal" / "fit.json").stat().st_mtime_ns for s in ("P01", "P02", "P03")}


def test_every_specimen_is_calibrated_validated_and_summarized(made):
    r = made / "results"
    for s in ("P01", "P02", "P03"):
        assert (r / "specimens" / s / "cal" / "fit.json").is_file()
        assert json.loads((r / "specimens" / s / "gate" / "metrics.json").read_text())["pass"] is True  # each fit passes its own gate on its held-out polish
    html = (r / "summary" / "report.html").read_text()
    assert 'id="population-table"' in html and html.count("<h3>") == 6  # one forest plot per constant
    assert html.count('class="forest"') >= 3  # drawn where specimens give estimates (compact)
    assert "../specimens/P02/gate/report.html" in html  # links to every specimen's report
    params = (r / "summary" / "params.toml").read_text()
    assert "format = 'burrbench.params'" in params
    assert all(f"specimens/{s}/cal/fit.json" in params for s in ("P01", "P02", "P03"))  # provenance


# Measures the drawn forest plots in the page as the browser laid them out: no two labels
# overlap and none leaves its plot (an axis caption once sat on its lower tick).
LAYOUT_PROBE = """<script>
window.addEventListener("load", () => {
  const found = [];
  const svgs = document.querySelectorAll("svg.forest");
  for (const svg of svgs) {
    const vb = svg.viewBox.baseVal;
    const boxes = [...svg.querySelectorAll("text")].map(t => [t.textContent, t.getBBox()]);
    boxes.forEach(([a, p], i) => {
      if (p.x < 0 || p.y < 0 || p.x + p.width > vb.width || p.y + p.height > vb.height) found.push("outside: " + a);
      for (const [b, q] of boxes.slice(i + 1))
        if (p.x < q.x + q.width && q.x < p.x + p.width && p.y < q.y + q.height && q.y < p.y + p.height)
          found.push(a + " / " + b);
    });
  }
  document.body.dataset.forests = svgs.length;
  document.body.dataset.marks = document.querySelectorAll("svg.forest rect.specimen, svg.forest polygon.population").length;
  document.body.dataset.overlaps = JSON.stringify(found);
});
</script>"""


def test_the_study_report_renders_in_a_browser_with_readable_forest_plots(made, tmp_path):
    sys.path.insert(0, str(SRC / "tests" / "analysis"))
    import browser_check
    report = made / "results" / "summary" / "report.html"
    res = json.loads(subprocess.run(["/usr/bin/python3", SRC / "tests" / "analysis" / "browser_check.py", report,
                                     tmp_path / "chromium"], capture_output=True, text=True, timeout=200,
                                    check=True).stdout)
    assert res["console_errors"] == []
    assert res["coloured_fraction"] > 0.0005  # the blue specimen marks and red population diamonds
    page = tmp_path / "probed.html"
    page.write_text(report.read_text().replace("</body>", LAYOUT_PROBE + "</body>"))
    dom = browser_check.chromium(["--dump-dom", page.as_uri()], str(tmp_path / "probe")).stdout
    body = re.search(r"<body[^>]*>", dom).group(0)
    attr = {k: v for k, v in re.findall(r'data-(\w+)="([^"]*)"', body)}
    assert int(attr["forests"]) >= 3, body
    assert int(attr["marks"]) >= 3 * 4  # 3 specimens and the population per drawn constant
    assert json.loads(attr["overlaps"].replace("&quot;", '"')) == []


def test_the_population_interval_holds_the_population_mean(made):
    truth = json.loads((made / "population_truth.json").read_text())["population_geometric_mean"]
    pop = json.loads((made / "results" / "summary" / "population.json").read_text())
    checked = 0
    for e in pop["estimates"]:
        if e["k"] < 2:
            assert e["excluded"], e  # a constant nobody identifies is listed, not pooled
            continue
        want = truth[e["class_name"]][e["parameter"]]
        assert e["ci95_low"] <= want <= e["ci95_high"], e
        assert e["tau_ln"] >= 0 and 0 <= e["i2"] <= 1
        checked += 1
    # Compact bone is cut by every recording: its three constants are always pooled.
    assert {(e["class_name"], e["parameter"]) for e in pop["estimates"] if e["k"] == 3} >= {
        ("compact", "alpha"), ("compact", "c1"), ("compact", "mu")}
    assert checked >= 3


def test_a_second_run_does_nothing_and_a_deleted_fit_redoes_only_its_specimen(made):
    before = fit_mtimes(made)
    os.utime(made / "P01" / "plunge.h5")  # touched, unchanged: content-addressed, nothing to redo
    p = study("run", made / "study.toml", "--out", made / "results", "--cores", "2")
    assert p.returncode == 0, p.stdout + p.stderr
    assert "Nothing to be done" in p.stdout + p.stderr
    assert fit_mtimes(made) == before
    (made / "results" / "specimens" / "P02" / "cal" / "fit.json").unlink()
    time.sleep(0.01)
    p = study("run", made / "study.toml", "--out", made / "results", "--cores", "2")
    assert p.returncode == 0, p.stdout + p.stderr
    after = fit_mtimes(made)
    assert after["P01"] == before["P01"] and after["P03"] == before["P03"]
    assert after["P02"] != before["P02"]
    log = p.stdout + p.stderr
    assert "wildcards: s=P02" in log and "wildcards: s=P01" not in log and "wildcards: s=P03" not in log
    # One changed byte in a specimen's inputs redoes that specimen alone.
    manifest = made / "P03" / "experiment.toml"
    manifest.write_text(manifest.read_text() + "# a changed byte\n")
    p = study("run", made / "study.toml", "--out", made / "results", "--cores", "2")
    assert p.returncode == 0, p.stdout + p.stderr
    log = p.stdout + p.stderr
    assert "wildcards: s=P03" in log and "wildcards: s=P01" not in log and "wildcards: s=P02" not in log


def test_the_slurm_profile_dry_runs(made, tmp_path):
    p = study("run", made / "study.toml", "--out", tmp_path / "fresh", "--profile", SRC / "study" / "profiles" / "slurm",
              "--dry-run")
    assert p.returncode == 0, p.stdout + p.stderr
    out = p.stdout + p.stderr
    assert out.count("rule calibrate:") == 3 and out.count("rule validate:") == 3 and "rule summarize:" in out
    assert not (tmp_path / "fresh" / "specimens").exists()  # a dry run runs nothing


def test_bad_study_manifests_are_refused_with_file_and_field(made, tmp_path):
    good = (made / "study.toml").read_text().replace('"P01/', f'"{made}/P01/').replace('"P02/', f'"{made}/P02/') \
        .replace('"P03/', f'"{made}/P03/').replace('criteria = "criteria.toml"', f'criteria = "{made}/criteria.toml"')
    cases = {
        "unknown_key": (good + "\ncolour = 1\n", "colour"),
        "missing_experiment": (good.replace(f'{made}/P02/experiment.toml', "nowhere.toml"), "specimen[1].experiment"),
        "duplicate_id": (good.replace('id = "P03"', 'id = "P01"'), "specimen[2].id"),
        "bad_id": (good.replace('id = "P03"', 'id = "../x"'), "specimen[2].id"),
        "bad_starts": (good.replace("starts = 2", "starts = 0"), "fit.starts"),
    }
    for name, (text, field) in cases.items():
        f = tmp_path / f"{name}.toml"
        f.write_text(text)
        r = study("run", f, "--out", tmp_path / name)
        assert_refused(r.returncode, r.stderr, f, field, label=name)
        assert not (tmp_path / name).exists()
    # summarize before any run names the missing fit
    f = tmp_path / "good.toml"
    f.write_text(good)
    r = study("summarize", f, "--results", tmp_path / "none")
    assert_refused(r.returncode, r.stderr, "fit.json", "study run", label="not run yet")


def test_the_same_study_runs_on_a_single_node_slurm(made, tmp_path):
    from slurm_node import SlurmUnavailable, start_slurm
    try:
        with start_slurm(tmp_path / "slurm") as env:
            p = subprocess.run([BURRBENCH, "study", "run", made / "study.toml", "--out", tmp_path / "onslurm",
                                "--profile", SRC / "study" / "profiles" / "slurm"],
                               capture_output=True, text=True, timeout=600, env=env)
            assert p.returncode == 0, p.stdout + p.stderr
            submitted = sorted((tmp_path / "onslurm" / "logs").glob("slurm-*.out"))
    except SlurmUnavailable as e:
        print(f"SKIPPED on this machine: {e}")
        pytest.skip(str(e))
    # 3 calibrations, 3 gates and the summary, each a Slurm job; the same numbers as locally.
    assert len(submitted) == 7, submitted
    local = json.loads((made / "results" / "summary" / "population.json").read_text())["estimates"]
    slurm = json.loads((tmp_path / "onslurm" / "summary" / "population.json").read_text())["estimates"]
    assert [e["mean"] for e in slurm] == pytest.approx([e["mean"] for e in local], rel=1e-6)


def test_a_folder_that_cannot_be_made_is_one_line_naming_it(made, tmp_path):
    # Issue 59, N7: `study run` into a folder it cannot create exited 3 with the C++
    # library's raw text ("filesystem error: cannot create directories: ... [path]").
    # Here the folder's parent is a regular file (root may write anywhere, so no chmod).
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder\n")
    p = study("run", made / "study.toml", "--out", blocker / "results", "--cores", "1", "--dry-run")
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 3 and len(lines) == 1, (p.returncode, p.stderr)
    assert str(blocker) in lines[0] and "Not a directory" in lines[0], lines
    assert "filesystem error" not in lines[0], lines
    assert blocker.read_text() == "not a folder\n"


def test_sigterm_stops_snakemake_and_its_jobs_too(made, tmp_path):
    # Issue 59, N6: SIGTERM to `study run` stopped burrbench only; Snakemake and its jobs
    # went on and wrote 56 files after it had exited. The signal is now forwarded to
    # Snakemake's process group and burrbench waits for it.
    out = tmp_path / "stopped"
    log = open(tmp_path / "run.log", "w")  # not a pipe: waiting for its end would wait for Snakemake too
    p = subprocess.Popen([BURRBENCH, "study", "run", str(made / "study.toml"), "--out", str(out), "--cores", "2"],
                         stdout=log, stderr=log, text=True)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not (out / ".snakemake").exists():
        time.sleep(0.2)  # until Snakemake runs
    time.sleep(2.0)  # and its first jobs have started
    p.terminate()
    p.wait(timeout=120)
    log.close()
    err = (tmp_path / "run.log").read_text()
    assert p.returncode != 0, err
    files = lambda: sorted(str(f) for f in out.rglob("*") if ".snakemake" not in f.parts)
    after_exit = files()
    left = subprocess.run(["pgrep", "-f", str(out)], capture_output=True, text=True).stdout.split()
    assert not left, ("processes still at work on the folder after burrbench exited", left)
    time.sleep(5)
    assert files() == after_exit, set(files()) - set(after_exit)
