#!/usr/bin/python3
"""Writes an example study: N synthetic specimens drawn from a known population (docs/study.md).

Per class and constant the population is log-normal: ln θ ~ N(ln θ_pop, SPREAD²), θ_pop
the synthetic reference experiment's truth (examples/experiments/synthetic). Each specimen
gets its own sample (`burrbench sample synth`, its own seed: a 0.5 mm cortex over a
trabecular core) and three recordings (`burrbench synth`, noise 0.02 N, a bias, its own
seed) made with its drawn constants: a plunge through the cortex into the trabecular core
(protocols/plunge.toml), the lateral sweeps of examples/protocols/sweep.toml and, held
out, polishing strokes at 0.2 mm (protocols/polish.toml). Writes OUTDIR/study.toml,
OUTDIR/criteria.toml, OUTDIR/population_truth.json and one folder per specimen with its
experiment.toml and params_true.toml (its drawn constants).

With --raw each specimen is left as a lab has it before any import: the CT as NRRD
(`burrbench sample export-nrrd`: labels + bone fraction, as 3D Slicer writes a
segmentation) and each recording as a LabVIEW-style CSV export read through
labview_map.toml; the study's workflow imports them ([specimen.sample],
[[specimen.recording]]). The synthesized .h5 files are removed.

Usage: make.py BURRBENCH OUTDIR [--specimens 4] [--seed 1] [--spread 0.1] [--starts 4] [--profiles] [--raw]
"""
import argparse
import json
import math
import random
import shutil
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
SYNTHETIC = HERE.parent / "experiments" / "synthetic"
PROTOCOLS = {"plunge": HERE / "protocols" / "plunge.toml",
             "sweep": HERE.parent / "protocols" / "sweep.toml",
             "polish": HERE / "protocols" / "polish.toml"}
LAGS_MS = {"plunge": 0, "sweep": 2, "polish": 2}
COMPACT_MM = 0.5  # the cortex: the plunge (0.8 mm) goes through it, sweeps and polish stay in it
# The population's geometric means: the synthetic experiment's truth.
POPULATION = {"compact": {"id": 1, "alpha_N_per_mm2": 500.0, "c1_N_per_mm2": 16.0, "mu": 0.4},
              "trabecular": {"id": 2, "alpha_N_per_mm2": 200.0, "c1_N_per_mm2": 6.0, "mu": 0.3}}
KEYS = {"alpha_N_per_mm2": "alpha", "c1_N_per_mm2": "c1", "mu": "mu"}
# The CSV export's columns (labview_map.toml): time in ms, stage in µm, decimal comma.
CSV_PREAMBLE = ["LabVIEW Measurement\t", "Operator\tburrbench example study", "***End_of_Header***\t"]
CSV_HEADER = ["Time [ms]", "Stage X [um]", "Stage Y [um]", "Stage Z [um]", "Fx [N]", "Fy [N]", "Fz [N]",
              "Spindle [rpm]"]


def run(*args):
    p = subprocess.run([str(a) for a in args], capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"make.py: {' '.join(map(str, args[:3]))} failed:\n{p.stdout}{p.stderr}")


def number(v):
    return repr(float(v)).replace(".", ",")


def write_csv(recording, csv):
    """The recording as a rig's PC would have exported it: one row per sample, every
    value at full precision (repr), so the import gives back the same numbers."""
    import h5py  # Debian's python3-h5py (scripts/install-deps)
    with h5py.File(recording, "r") as f:
        ft, stage, spindle = f["streams/ft_sensor"], f["streams/stage"], f["streams/spindle"]
        t_ns = ft["t_ns"][()]
        if not (len(stage["t_ns"]) == len(spindle["t_ns"]) == len(t_ns)):
            sys.exit(f"make.py: {recording}: its streams differ in length; a CSV row needs one time")
        force, pos, rpm = ft["channels/force_N"][()], stage["channels/position_mm"][()], spindle["channels/spindle_rpm"][()]
    lines = CSV_PREAMBLE + ["\t".join(CSV_HEADER)]
    t0 = int(t_ns[0])
    for k in range(len(t_ns)):
        row = [(int(t_ns[k]) - t0) * 1e-6] + [x * 1000.0 for x in pos[k]] + list(force[k]) + [rpm[k]]
        lines.append("\t".join(number(v) for v in row))
    csv.write_text("\n".join(lines) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("burrbench")
    ap.add_argument("outdir")
    ap.add_argument("--specimens", type=int, default=4)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--spread", type=float, default=0.1, help="SD of ln θ across specimens")
    ap.add_argument("--starts", type=int, default=4, help="multistart points per calibration")
    ap.add_argument("--profiles", action="store_true", help="profile likelihoods in every fit (slower)")
    ap.add_argument("--raw", action="store_true", help="leave each specimen as NRRD + CSV files for the workflow to import")
    a = ap.parse_args()
    if not 1 <= a.specimens <= 500:
        sys.exit("make.py: --specimens: expected 1..500")
    out = Path(a.outdir)
    out.mkdir(parents=True, exist_ok=True)
    rng = random.Random(a.seed)
    truth = {"spread_ln": a.spread, "seed": a.seed, "population_geometric_mean": {}, "specimens": {}}
    for cls, vals in POPULATION.items():
        truth["population_geometric_mean"][cls] = {KEYS[k]: v for k, v in vals.items() if k in KEYS}
    lines = ['format = "burrbench.study"', f'format_version = "{"1.1" if a.raw else "1.0"}"',
             f'name = "example study ({a.specimens} specimens{", from raw files" if a.raw else ""})"',
             f'description = "synthetic specimens from a log-normal population, spread {a.spread} in ln, seed {a.seed}"',
             'criteria = "criteria.toml"', "", "[fit]", f"starts = {a.starts}",
             f"profiles = {'true' if a.profiles else 'false'}", "cross_validation = false",
             "discretization_check = false", ""]
    shutil.copy(HERE.parent / "criteria" / "release.toml", out / "criteria.toml")
    if a.raw:
        shutil.copy(HERE / "labview_map.toml", out / "labview_map.toml")
    for i in range(1, a.specimens + 1):
        sid = f"P{i:02d}"
        d = out / sid
        d.mkdir(exist_ok=True)
        drawn = {}
        params = ['format = "burrbench.params"', 'format_version = "1.0"', f'notes = "truth of specimen {sid}"']
        for cls, vals in POPULATION.items():
            params += ["", f"[classes.{cls}]", f"id = {vals['id']}"]
            drawn[cls] = {}
            for key in KEYS:
                v = vals[key] * math.exp(a.spread * rng.gauss(0.0, 1.0))
                params.append(f"{key} = {v!r}")
                drawn[cls][KEYS[key]] = v
        (d / "params_true.toml").write_text("\n".join(params) + "\n")
        shutil.copy(SYNTHETIC / "experiment.toml", d / "experiment.toml")
        truth["specimens"][sid] = drawn
        seed = a.seed * 1000 + i * 10
        run(a.burrbench, "sample", "synth", "--extent-mm", 8, 8, 3, "--voxel-mm", 0.1, "--compact-mm", COMPACT_MM,
            "--seed", seed, "--out", d / "sample.h5", "--overwrite")
        for k, rec in enumerate(PROTOCOLS):
            run(a.burrbench, "synth", "--sample", d / "sample.h5", "--protocol", PROTOCOLS[rec],
                "--params", d / "params_true.toml", "--out", d / f"{rec}.h5", "--truth", d / f"{rec}.truth.json",
                "--noise-N", 0.02, "--bias-N", "0.05,-0.03,0.1", "--lag-ms", LAGS_MS[rec], "--seed", seed + k + 1,
                "--overwrite")
        lines += ["[[specimen]]", f'id = "{sid}"', f'experiment = "{sid}/experiment.toml"']
        if a.raw:
            run(a.burrbench, "sample", "export-nrrd", d / "sample.h5", "--out-prefix", d / "ct", "--overwrite")
            (d / "sample.h5").unlink()
            lines += ["  [specimen.sample]                # the CT's segmentation, as NRRD",
                      f'  labels = "{sid}/ct_labels.nrrd"', f'  fraction = "{sid}/ct_fraction.nrrd"']
            for rec in PROTOCOLS:
                write_csv(d / f"{rec}.h5", d / f"{rec}.csv")
                (d / f"{rec}.h5").unlink()
                lines += ["  [[specimen.recording]]", f'  id = "{rec}"', f'  raw_csv = "{sid}/{rec}.csv"',
                          '  column_map = "labview_map.toml"']
        lines.append("")
    (out / "study.toml").write_text("\n".join(lines))
    (out / "population_truth.json").write_text(json.dumps(truth, indent=1) + "\n")
    print(f"study ready: {out / 'study.toml'} ({a.specimens} specimens{', raw NRRD + CSV' if a.raw else ''})")


if __name__ == "__main__":
    main()
