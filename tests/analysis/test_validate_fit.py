"""The dossier's link from a fit to its release gate (issue 14): `calibrate --criteria`
records the acceptance criteria's SHA-256 in fit.json before it fits, and `validate --fit`
brings that fit into the report (intervals, correlations, search, nuisances, both command
lines) and says whether the criteria it checks are the ones fixed before the fit."""
import json
import shutil
import subprocess

import pytest

from bad_input import assert_refused
from synthetic import BURRBENCH, SRC, make_synthetic, run_ok
from report_context import context

CRITERIA = SRC / "examples" / "criteria" / "release.toml"


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    d = make_synthetic(tmp_path_factory.mktemp("fitted"))
    shutil.copy(CRITERIA, d / "criteria.toml")
    run_ok("calibrate", d / "experiment.toml", "--out", d / "cal", "--criteria", d / "criteria.toml",
           "--no-cross-validation", "--no-discretization-check")
    run_ok("calibrate", d / "experiment.toml", "--out", d / "plain", "--no-cross-validation",
           "--no-discretization-check", "--no-profiles")
    return d


def gate(d, out, fit, criteria, params=None, verification=False):
    return subprocess.run([BURRBENCH, "validate", d / "experiment.toml", "--params", params or fit.parent / "params.toml",
                           "--criteria", criteria, "--fit", fit, "--out", out]
                          + ([] if verification else ["--no-verification"]),
                          capture_output=True, text=True, timeout=600)


def with_a_limited_constant(fit_file, out):
    """fit.json as calibrate writes it when its discretization check finds compact alpha
    limited (docs/calibration.md "Discretization check": the estimate at 2l moved by more
    than half its 95 % interval, the interval widened by that move), written to `out`."""
    import math
    fit = json.loads(fit_file.read_text())
    p = next(p for p in fit["parameters"] if (p["class_name"], p["name"]) == ("compact", "alpha"))
    assert p["identifiable"] and p["verdict"] == "identifiable", p
    move = 2 * math.log(p["profile_ci95_high"] / p["estimate"])
    p["discretization"] = {"coarse_estimate": p["estimate"] * math.exp(move), "error_log": move, "limited": True,
                           "ci95_low": p["profile_ci95_low"] * math.exp(-move),
                           "ci95_high": p["profile_ci95_high"] * math.exp(move)}
    out.write_text(json.dumps(fit, indent=1))
    return out


def test_calibrate_records_the_criteria(fitted):
    fit = json.loads((fitted / "cal" / "fit.json").read_text())
    rec = fit["settings"]["criteria"]
    import hashlib
    assert rec["sha256"] == hashlib.sha256((fitted / "criteria.toml").read_bytes()).hexdigest()
    assert any(i["sha256"] == rec["sha256"] for i in fit["provenance"]["inputs"])
    assert "criteria" not in json.loads((fitted / "plain" / "fit.json").read_text())["settings"]


def test_validate_with_the_fit_brings_its_intervals_and_the_criteria_predate_it(fitted, tmp_path):
    p = gate(fitted, tmp_path / "gate", fitted / "cal" / "fit.json", fitted / "criteria.toml")
    assert p.returncode == 0, p.stdout + p.stderr
    assert "criteria: Fixed before the fit" in p.stdout
    out = tmp_path / "gate"
    assert (out / "fit.json").read_bytes() == (fitted / "cal" / "fit.json").read_bytes()
    assert json.loads((out / "metrics.json").read_text())["criteria_predate_fit"] is True
    html = (out / "report.html").read_text()
    assert "CRITERIA FIXED BEFORE THE FIT" in html
    # When: the time calibrate read the criteria (fit.json settings.criteria.recorded_utc)
    # beside the fit's own start (settings.started_utc), on the terminal, in section 13 and
    # in section 15. Checked against the provenance stamp, taken before the last stage,
    # "overlaps", less the solver's wall time without that stage: whole seconds both, so
    # within two.
    import datetime
    fit = json.loads((fitted / "cal" / "fit.json").read_text())
    recorded = fit["settings"]["criteria"]["recorded_utc"]
    started = fit["settings"]["started_utc"]
    iso = "%Y-%m-%dT%H:%M:%SZ"
    start = datetime.datetime.strptime(started, iso)
    wall = fit["solver"]["wall_s"] - sum(s["wall_s"] for s in fit["solver"]["stages"] if s["stage"] == "overlaps")
    stamped = datetime.datetime.strptime(fit["provenance"]["created_utc"], iso)
    assert abs((stamped - start).total_seconds() - wall) <= 2, (started, fit["provenance"]["created_utc"], wall)
    assert datetime.datetime.strptime(recorded, iso) <= start, (recorded, started)
    when = f"recorded {recorded}; the fit started {started}"
    assert when in p.stdout and when in html[html.index('id="criteria-predate"'):], (when, p.stdout)
    seeds = html[html.index('id="repro"'):]
    assert f"<th>criteria recorded by the fit (UTC)</th><td>{recorded}</td>" in seeds
    assert f"<th>fit started (UTC)</th><td>{started}</td>" in seeds
    assert f"<th>criteria sha256 recorded by the fit</th><td>{fit['settings']['criteria']['sha256']}</td>" in seeds
    params = html[html.index('id="params"'):html.index('id="force"')]
    fit = json.loads((fitted / "cal" / "fit.json").read_text())
    # The fit's profile intervals, waterfall, correlations and nuisances are in the dossier.
    assert "profile 95 %" in params and "plot-waterfall" in params and "Parameter correlation matrix" in params
    assert 'id="nuisance-table"' in params and "<td>plunge</td><td>lag</td>" in params
    # Both command lines: the calibration's (from fit.json) and the gate's.
    repro = html[html.index('id="repro"'):]
    assert "calibrate" in fit["provenance"]["command_line"]
    assert fit["provenance"]["command_line"].split()[1] in repro and "validate" in repro


def test_criteria_changed_after_the_fit_are_flagged(fitted, tmp_path):
    changed = tmp_path / "looser.toml"
    changed.write_text((fitted / "criteria.toml").read_text().replace("max = 0.10", "max = 0.30"))
    p = gate(fitted, tmp_path / "gate", fitted / "cal" / "fit.json", changed)
    assert p.returncode == 0, p.stdout + p.stderr  # the gate itself is the criteria's
    assert "criteria: Changed after the fit" in p.stdout
    html = (tmp_path / "gate" / "report.html").read_text()
    assert "CRITERIA CHANGED AFTER THE FIT" in html
    assert json.loads((tmp_path / "gate" / "metrics.json").read_text())["criteria_predate_fit"] is False
    # A fit that recorded no criteria: not established, said so.
    p = gate(fitted, tmp_path / "gate2", fitted / "plain" / "fit.json", fitted / "criteria.toml")
    assert p.returncode == 0, p.stdout + p.stderr
    assert "criteria: Not established" in p.stdout
    assert json.loads((tmp_path / "gate2" / "metrics.json").read_text())["criteria_predate_fit"] is None
    # Without --fit the fit.json is not the report's and the check is absent.
    p = subprocess.run([BURRBENCH, "validate", fitted / "experiment.toml", "--params", fitted / "cal" / "params.toml",
                        "--criteria", fitted / "criteria.toml", "--out", tmp_path / "gate3", "--no-verification"],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0 and "criteria:" not in p.stdout
    assert "criteria_predate_fit" not in json.loads((tmp_path / "gate3" / "metrics.json").read_text()) or \
        json.loads((tmp_path / "gate3" / "metrics.json").read_text())["criteria_predate_fit"] is None


def test_parameters_from_another_fit_are_refused(fitted, tmp_path):
    other = tmp_path / "other.toml"
    other.write_text((fitted / "params_true.toml").read_text())
    p = gate(fitted, tmp_path / "gate", fitted / "cal" / "fit.json", fitted / "criteria.toml", params=other)
    assert_refused(p.returncode, p.stderr, other, "classes.", "the value the fit held")
    assert not (tmp_path / "gate").exists()


def test_calibrate_refuses_broken_criteria_before_fitting(fitted, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text((fitted / "criteria.toml").read_text().replace('metric = "nrmse"', 'metric = "nrsme"'))
    p = subprocess.run([BURRBENCH, "calibrate", fitted / "experiment.toml", "--out", tmp_path / "cal", "--criteria", bad],
                       capture_output=True, text=True, timeout=120)
    assert_refused(p.returncode, p.stderr, bad, "metric")
    assert not (tmp_path / "cal").exists()


def test_the_dossier_draws_every_section_and_plot_and_prints_every_column(fitted, tmp_path):
    """The browser test of the whole dossier: every section's heading, a drawn canvas for
    every plot, no console error; the structured context of use, the data-quality table,
    the residual diagnostics and the sign-off; the verdicts a reviewer must not miss — the
    verification's and a constant limited by discretization error — in the first screen,
    beside the gate; no table wider than the printed page; and, printed to PDF and rendered
    to PNG, the parameter table's last column."""
    import re
    import sys
    cal = tmp_path / "cal"
    cal.mkdir()
    shutil.copy(fitted / "cal" / "params.toml", cal / "params.toml")
    fit = with_a_limited_constant(fitted / "cal" / "fit.json", cal / "fit.json")
    p = gate(fitted, tmp_path / "gate", fit, fitted / "criteria.toml", verification=True)
    assert p.returncode == 0, p.stdout + p.stderr
    report = tmp_path / "gate" / "report.html"
    html = report.read_text()
    # The parameter table's verdict for the limited constant says so, beside its 2l column.
    params = html[html.index('id="params"'):html.index('id="force"')]
    row = params[params.index("<td>compact</td><td>alpha</td>"):]
    row = row[:row.index("</tr>")]
    assert "<b>limited</b>" in row and "<b>identifiable, limited by discretization error</b>" in row, row
    headings = re.findall(r'<h2 id="[a-z]+">(\d+)\. ', html)
    assert headings == [str(i) for i in range(1, 17)], headings
    # V&V 40 context from the criteria's [context]: influence high × consequence low → medium.
    cou = html[html.index('id="cou-table"'):html.index('id="model"')]
    assert "question of interest" in cou and "<b>medium</b> (from influence and consequence" in cou
    quality = html[html.index('id="quality-table"'):html.index('id="calib"')]
    for rid in ("plunge", "sweep", "polish"):
        assert f"<td>{rid}</td>" in quality
    assert 'id="signoff-table"' in html
    # The Durbin–Watson note says what metrics.json's whole-recording rows say.
    rows = json.loads((tmp_path / "gate" / "metrics.json").read_text())["rows"]
    flagged = [r for r in rows if r["segment"] == "all" and r["durbin_watson"] is not None
               and abs(r["durbin_watson"] - 2) > 0.5]
    note = html[html.index('id="dw-note"'):html.index('id="cv"')]
    assert ("AUTOCORRELATED RESIDUALS" in note) == bool(flagged)
    assert note.count("<li>") == min(len(flagged), 12) + (len(flagged) > 12)
    # The class map marks exactly the columns the depth map shows removed, with labels of
    # the sample's classes.
    import h5py
    classes = context(tmp_path / "gate")["samples"]
    with h5py.File(tmp_path / "gate" / "prediction.h5") as f:
        for sid, smp in f["samples"].items():
            depth, cls = smp["removed_depth_mm"][()].ravel(), smp["removed_class"][()].ravel()
            assert [d > 0 for d in depth] == [c > 0 for c in cls]
            assert {int(c) for c in cls if c} <= {int(k) for k in classes[sid]["classes"]}
    check = str(SRC / "tests" / "analysis" / "browser_check.py")
    seen = json.loads(subprocess.run(["/usr/bin/python3", check, str(report), str(tmp_path / "chromium")],
                                     capture_output=True, text=True, timeout=300, check=True).stdout)
    assert seen["console_errors"] == []
    plots = re.findall(r'<div class="plot" id="(plot-[a-z0-9-]+)"', html)
    assert {"plot-qq-0", "plot-acf-0", "plot-qq-1", "plot-acf-1", "plot-waterfall"} <= set(plots)
    for pid in plots:
        assert re.search(rf'id="{pid}" data-rendered="1"', seen["dom"]), pid
    assert seen["dom"].count("<canvas") >= len(plots)
    printed = json.loads(subprocess.run(["/usr/bin/python3", check, str(report), str(tmp_path / "print"), "--print"],
                                        capture_output=True, text=True, timeout=400, check=True).stdout)
    assert printed["found"] and printed["inside_page"], printed
    assert printed["dark_pixels"] > 20, printed  # the word "verdict" is drawn on the page
    shown = json.loads(subprocess.run(["/usr/bin/python3", check, str(report), str(tmp_path / "layout"), "--layout",
                                       "verdict", "verification-badge", "constants-verdict"],
                                      capture_output=True, text=True, timeout=400, check=True).stdout)
    # Every table within the printed page: the correlation matrix of the fit's constants and
    # nuisances is the widest.
    assert shown["print_width_measured"] == shown["printable_width_px"], shown
    assert 'id="correlation-table"' in html and shown["cut"] == [], shown["cut"]
    first = shown["first_screen"]
    assert first.keys() == {"verdict", "verification-badge", "constants-verdict"}, first
    assert all(v["inside"] for v in first.values()), first
    verification = context(tmp_path / "gate")["verification"]
    assert first["verification-badge"]["text"] == "VERIFICATION: DISCRETIZATION ERROR " + (
        "BELOW NOISE" if verification["below_noise"] else "ABOVE NOISE"), first
    assert "compact alpha: identifiable, limited by discretization error" in first["constants-verdict"]["text"], first


def test_the_fit_settings_read_as_tables_not_json(fitted, tmp_path):
    # Section 5 shows fit.json's settings, solver and residual summary to a reviewer: nested
    # settings as tables, the stages and each recording's registration as one table each,
    # numbers to 6 significant digits (fit.json keeps every digit), no raw JSON.
    import re
    run_ok("report", fitted / "cal", "--out", tmp_path / "r" / "report.html")
    html = (tmp_path / "r" / "report.html").read_text()
    section = html[html.index('id="calib"'):html.index('id="params"')]
    assert "{&quot;" not in section and '{"' not in section and "[{" not in section, section[:2000]
    reals = re.findall(r"<td(?: class=\"num\")?>(-?\d+\.\d+)(?:e[-+]\d+)?</td>", section)
    assert len(reals) > 10, section[:2000]
    for r in reals:
        assert len(r.lstrip("-").replace(".", "").lstrip("0")) <= 6, r
    fit = json.loads((fitted / "cal" / "fit.json").read_text())
    stages = section[section.index("<th>stages</th>"):]
    for st in fit["solver"]["stages"]:
        assert f"<td>{st['stage']}</td>" in stages, st
    assert "<th>plunge</th>" in section and "<th>sweep</th>" in section  # registration, a row each
    assert f"<td>{fit['settings']['residual_variance']:.6g}</td>" in section
    assert f"<td>{fit['residuals_summary']['sigma_N']:.6g}</td>" in section
    # It says which nuisances the replay applied from the fit, and that without fiducials
    # no pose was fitted, so the registration's uncertainty is not in the intervals.
    free = {n["name"] for n in fit["nuisance"] if not n["fixed"]}
    applied = [w for w, on in (("bias", "bias_x" in free), ("lag", "lag" in free),
                               ("depth offset", "depth_offset" in free)) if on]
    assert f"<th>nuisances applied</th><td>from fit.json: {', '.join(applied)}</td>" in section, section[:1500]
    assert "the fit estimated no pose" in html and "calibrate fitted its pose correction" not in html


def test_a_broken_context_of_use_is_refused(fitted, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text((fitted / "criteria.toml").read_text().replace('model_influence = "high"', 'model_influence = "huge"'))
    p = gate(fitted, tmp_path / "gate", fitted / "cal" / "fit.json", bad)
    assert_refused(p.returncode, p.stderr, bad, "context.model_influence", "low")
    assert not (tmp_path / "gate").exists()


def test_the_prediction_band_matches_central_differences_of_whole_replays(fitted, tmp_path):
    """validate --fit draws a 95 % band around the predicted force from the fit's
    covariance: 1.96·√(gᵀCg) with g = ∂F/∂ln θ from the forward sensitivities. Checked
    against g from central differences of `burrbench replay` runs with each fitted
    constant moved by ±h in ln θ."""
    import math
    import tomllib

    import h5py
    import numpy as np
    out = tmp_path / "gate"
    p = gate(fitted, out, fitted / "cal" / "fit.json", fitted / "criteria.toml")
    assert p.returncode == 0, p.stdout + p.stderr
    with h5py.File(out / "prediction.h5") as f:
        band = {rid: np.array(g["band95_N"][()]) for rid, g in f["recordings"].items() if "band95_N" in g}
    assert "polish" in band
    fit = json.loads((fitted / "cal" / "fit.json").read_text())
    names, cov = fit["covariance"]["names"], fit["covariance"]["matrix"]
    params = tomllib.loads((fitted / "cal" / "params.toml").read_text())["classes"]
    keys = {"alpha": "alpha_N_per_mm2", "c1": "c1_N_per_mm2", "mu": "mu"}
    free = [n for n in names if n.split(".")[0] in params and n.split(".")[1] in keys]
    assert free, names

    def write_params(path, moved=None, h=0.0):
        lines = ['format = "burrbench.params"', 'format_version = "1.0"']
        for cls, c in params.items():
            lines += [f"[classes.{cls}]", f"id = {c['id']}"]
            for k, key in keys.items():
                v = c[key] * (math.exp(h) if moved == f"{cls}.{k}" else 1.0)
                lines.append(f"{key} = {v!r}")
        path.write_text("\n".join(lines) + "\n")

    def replay(name, moved=None, h=0.0):
        write_params(tmp_path / f"{name}.toml", moved, h)
        run_ok("replay", fitted / "experiment.toml", "--params", tmp_path / f"{name}.toml", "--out", tmp_path / f"{name}.h5")
        with h5py.File(tmp_path / f"{name}.h5") as f:
            return np.array(f["recordings/polish/force_sensor_pred_N"][()])

    h = 1e-3
    g = [(replay(f"p{i}", n, h) - replay(f"m{i}", n, -h)) / (2 * h) for i, n in enumerate(free)]
    idx = [names.index(n) for n in free]
    value = [params[n.split(".")[0]][keys[n.split(".")[1]]] for n in free]
    m = len(names)
    c_ln = np.array([[cov[idx[a] * m + idx[b]] / (value[a] * value[b]) for b in range(len(free))] for a in range(len(free))])
    want = 1.959963984540054 * np.sqrt(np.maximum(np.einsum("aki,ab,bki->ki", np.array(g), c_ln, np.array(g)), 0))
    got = np.array(band["polish"])
    assert got.shape == want.shape
    big = want > 0.05 * want.max()
    assert big.sum() > 100
    rel = np.abs(got[big] - want[big]) / want[big]
    print(f"band vs central differences: {big.sum()} values, relative difference median {np.median(rel):.2e}, "
          f"95th percentile {np.percentile(rel, 95):.2e}; widest band {want.max():.4g} N")
    assert np.median(rel) < 0.01 and np.percentile(rel, 95) < 0.05, (np.median(rel), np.percentile(rel, 95))
    html = (out / "report.html").read_text()
    assert "95 % band" in html[html.index('id="force"'):html.index('id="wrench"')]
