"""`make demo` end to end (scripts/demo): virtual rig over Modbus TCP → acquire →
calibrate → validate → report. The fit of the acquired sessions must recover the truth the
virtual rig played, within the calibration issue's tolerances."""
# ctest: load (issue 59: its promises hold beside two busy processes; make test-loaded)
# ctest: run serial (the virtual rig plays and the acquirer polls in real time at 200 Hz on
# this machine's two cores: under `ctest -j2` a neighbour's load delayed both by up to 16 ms
# (p99 jitter), and once put compact μ 9 % off with an interval that missed the truth)
import json
import math
import os
import re
import subprocess
import tomllib

import pytest

from report_context import context

SOURCE = os.environ["BURRBENCH_SOURCE_DIR"]
BUILD = os.environ["BURRBENCH_BUILD_DIR"]
TOLERANCE = {"c1": 0.02, "mu": 0.05, "alpha": 0.10}
KEYS = {"alpha": "alpha_N_per_mm2", "c1": "c1_N_per_mm2", "mu": "mu"}


LAG_WARNING = "follows the prediction best at a lag"  # analysis::LagMismatch::text


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo") / "demo"
    run = subprocess.run([os.path.join(SOURCE, "scripts", "demo"), BUILD],
                         env={**os.environ, "DEMO_OUT": str(out)},
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stdout + run.stderr
    return out, run


def test_demo_recovers_truth_and_writes_report(demo, tmp_path):
    out, run = demo
    assert f"report:     {out}/validate/report.html" in run.stdout
    assert "gate:       PASS" in run.stdout
    # The summary's lines align: label padded to 12, the constants after a space.
    for cls in ("compact", "trabecular"):
        assert f"\n{cls + ':':<12}alpha " in run.stdout, run.stdout

    # every session was acquired over Modbus, not copied from the synthetic file
    for rec in ("plunge", "sweep", "polish"):
        log = (out / f"acquire-{rec}.log").read_text()
        assert "acquiring 3 device(s)" in log, log
        assert (out / "acquired" / f"{rec}.h5").stat().st_size > 0

    fit = json.loads((out / "fit" / "fit.json").read_text())
    truth = tomllib.loads(
        open(os.path.join(SOURCE, "examples/experiments/demo/params_true.toml")).read())["classes"]
    checked = 0
    for p in fit["parameters"]:
        assert p["identifiable"], p
        true = truth[p["class_name"]][KEYS[p["name"]]]
        rel = abs(p["estimate"] - true) / true
        # Within the tolerance, or within the profile interval widened from 95 % to
        # 99.9 % (×3.29/1.96 in ln θ): the demo's trabecular C1 interval is ±1.5 %, its
        # seeded noise alone puts the estimate at −1.0 % (fit of the synthetic files), and
        # acquisition timing spreads it by ±0.7 % (six runs: −0.1 … −2.2 %), so a 2 % bound
        # alone fails a few runs in a hundred on sound fits. A bias of several σ still fails.
        lo, hi = math.log(p["profile_ci95_low"]), math.log(p["profile_ci95_high"])
        mid, z = math.log(p["estimate"]), 3.29 / 1.96
        inside = mid - z * (mid - lo) <= math.log(true) <= mid + z * (hi - mid)
        assert rel <= TOLERANCE[p["name"]] or inside, (p["class_name"], p["name"], p["estimate"], true,
                                                       p["profile_ci95_low"], p["profile_ci95_high"])
        checked += 1
    assert checked == 6  # α, C1, μ for compact and trabecular

    # the lag the rig data carries (4 ms synthetic) is found within its interval's reach
    lags = [n for n in fit["nuisance"] if n["name"] == "lag"]
    assert lags and all(abs(n["estimate"] - 4.0) < 2.0 for n in lags), lags
    # The manifest states that lag (examples/experiments/demo), so the gate, which replays at
    # it, finds no recording that follows the prediction better at another.
    assert LAG_WARNING not in (out / "validate.log").read_text()

    html = (out / "validate" / "report.html").read_text()
    assert "http://" not in html and "https://" not in html

    # The report's data-quality table counts what the acquired files hold (stale rows per
    # stream, events by kind), read here with h5py.
    import h5py
    recs = context(out / "validate")["recordings"]
    for rid, rec in recs.items():
        q = rec["quality"]
        with h5py.File(out / "acquired" / f"{rid}.h5") as f:
            stale = {name: int(f[f"streams/{name}/stale"][()].sum()) for name in f["streams"]}
            kinds = [k.decode() for k in f["events/kind"][()]]
        assert q["stale_rows"] == stale, (rid, q["stale_rows"], stale)
        # Beside the session's log the report lists the stretches without force samples the
        # replay found (kind force_silent, after a FIFO overrun on a loaded host).
        logged = [e for e in q["events"] if e["kind"] != "force_silent"]
        assert len(logged) == len(kinds) and [e["kind"] for e in logged] == kinds
    assert any(e["kind"] == "gap" for r in recs.values() for e in r["quality"]["events"])

    # The Python notebook (examples/python/demo.ipynb) runs on the demo's outputs: it loads
    # the fit, plots measured against predicted force and replays with a changed μ.
    nb = subprocess.run(["/usr/bin/python3", "-m", "nbconvert", "--to", "notebook", "--execute", "--output",
                         str(tmp_path / "demo.ipynb"), os.path.join(SOURCE, "examples", "python", "demo.ipynb")],
                        env={**os.environ, "BURRBENCH_DEMO": str(out), "PYTHONPATH": os.path.join(BUILD, "python")},
                        capture_output=True, text=True, timeout=600)
    assert nb.returncode == 0, nb.stderr[-3000:]
    done = json.loads((tmp_path / "demo.ipynb").read_text())
    outputs = [o for c in done["cells"] if c["cell_type"] == "code" for o in c["outputs"]]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    assert any("image/png" in o.get("data", {}) for o in outputs)  # the force plot was drawn


def summary_line(stdout, label):
    """The text of the summary's line `label:` (label padded to 12)."""
    found = [line[12:] for line in stdout.splitlines() if line.startswith(f"{label + ':':<12}")]
    assert len(found) == 1, (label, stdout)
    return found[0]


def test_demo_shows_calibrate_progress_as_it_goes(demo):
    """Not a minute of silence: calibrate's live line reaches the demo's stderr (a line every
    5 s in a log), with the whole run's fraction, rising, and the time left."""
    _, run = demo
    shown = [(float(m.group(1)), m.group(0)) for m in
             re.finditer(r"^ {6}calibrate \[[^\]]+\]: +(\d+\.\d)% .*$", run.stderr, re.M)]
    assert len(shown) >= 3, run.stderr
    fractions = [f for f, _ in shown]
    assert fractions == sorted(fractions) and 0 <= fractions[0] and fractions[-1] <= 100, fractions
    assert any(re.search(r", ~\d+ (s|min) left\]$", line) for _, line in shown), shown
    assert re.search(r"^ {6}calibrate: done: \d+ replays", run.stderr, re.M), run.stderr


def test_demo_summary_names_limits_verification_and_losses(demo):
    """The summary's lines agree with the files they summarise: the constants fit.json flags
    as limited by discretization error, the validate run's verification error against the
    noise, and the FIFO records the acquisitions lost."""
    out, run = demo
    fit = json.loads((out / "fit" / "fit.json").read_text())
    limited = summary_line(run.stdout, "limited")
    flagged = [(p["class_name"], p["name"]) for p in fit["parameters"]
               if (p.get("discretization") or {}).get("limited")]
    if flagged:
        assert limited.startswith("by discretization error: "), limited
        for cls, name in flagged:
            assert re.search(rf"{cls} [a-z1, ]*\b{name}\b", limited), (cls, name, limited)
    else:
        assert limited.startswith("none by discretization error"), limited
    v = context(out / "validate")["verification"]
    verify = summary_line(run.stdout, "verify")
    assert verify.startswith(f"discretization error in force {v['largest_error_N']:.3g} N ({v['worst_recording']}) "
                             f"against the sensor noise {v['sigma_N']:.3g} N: "), verify
    assert verify.endswith(("below it (report section 3)" if v["below_noise"] else "above it (report section 3)"))
    lost = {}
    for rec in ("plunge", "sweep", "polish"):
        for m in re.finditer(r"^warning: (\S+) lost (\d+) of", (out / f"acquire-{rec}.log").read_text(), re.M):
            lost[m.group(1)] = lost.get(m.group(1), 0) + int(m.group(2))
    said = summary_line(run.stdout, "lost")
    if lost:
        for dev, n in lost.items():
            assert f"{dev} {n} of " in said, (lost, said)
    else:
        assert said == "no FIFO record lost in acquisition", said


def test_validate_with_the_fit_replays_at_its_nuisances(demo, tmp_path):
    """`validate --fit` on the demo replays the calibration recordings at the fit's lag,
    biases and spindle terms: its pooled calibration RMSE (x, y, z together, from
    metrics.json's per-axis rows) is the fit's own (fit.json metrics.calibration), nothing
    warns of a lag, and the report says what it applied to each recording."""
    out, _ = demo
    gate = tmp_path / "gate"
    p = subprocess.run([os.path.join(BUILD, "apps", "burrbench"), "validate", out / "acquired" / "experiment.toml",
                        "--params", out / "fit" / "params.toml", "--fit", out / "fit" / "fit.json",
                        "--criteria", os.path.join(SOURCE, "examples", "criteria", "release.toml"),
                        "--out", gate, "--no-verification"], capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stdout + p.stderr
    assert LAG_WARNING not in p.stderr, p.stderr
    fit = json.loads((out / "fit" / "fit.json").read_text())
    rows = {r["axis"]: r for r in json.loads((gate / "metrics.json").read_text())["rows"]
            if r["recording"] == "" and r["role"] == "calibrate" and r["segment"] == "all"}
    want = fit["metrics"]["calibration"]
    assert rows["x"]["n"] == want["samples"]
    got = math.sqrt(sum(rows[a]["rmse_N"] ** 2 for a in "xyz") / 3)
    print(f"calibration RMSE: validate --fit {got!r} N, fit.json {want['rmse_xyz_N']!r} N")
    assert abs(got - want["rmse_xyz_N"]) <= 1e-6, (got, want)
    # Each recording at the fit's lag where the fit has one, else at the manifest's 4 ms,
    # and the report's table of what was applied says which.
    fitted = {n["recording_id"]: n["estimate"] for n in fit["nuisance"] if n["name"] == "lag" and not n["fixed"]}
    assert set(fitted) == {"plunge", "sweep"}, fitted
    import h5py
    with h5py.File(gate / "prediction.h5") as f:
        replayed = {rid: float(g.attrs["lag_ms"]) for rid, g in f["recordings"].items()}
    assert replayed == {**fitted, "polish": 4.0}, replayed
    html = (gate / "report.html").read_text()
    applied = html[html.index('id="applied-table"'):]
    applied = applied[:applied.index("</table>")]
    for rid, lag in replayed.items():
        source = "fit.json" if rid in fitted else "manifest"
        assert f"<td>{rid}</td><td class=\"num\">{lag:.4g}</td><td>{source}</td>" in applied, (rid, applied)
