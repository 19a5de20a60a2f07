#!/usr/bin/python3
"""Writes an example study: N synthetic specimens drawn from a known population (docs/study.md).

Per class and constant the population is log-normal: ln θ ~ N(ln θ_pop, SPREAD²), θ_pop
the synthetic reference experiment's truth (examples/experiments/synthetic). Each specimen
gets its own sample (`burrbench sample synth`, its own seed) and the plunge, sweep and
polish recordings (`burrbench synth`, noise 0.02 N, a bias, its own seed) made with its
drawn constants. Writes OUTDIR/study.toml, OUTDIR/population_truth.json and one folder per
specimen. Usage: make.py BURRBENCH OUTDIR [--specimens 4] [--seed 1] [--spread 0.1] [--starts 4]
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
PROTOCOLS = HERE.parent / "protocols"
# The population's geometric means: the synthetic experiment's truth.
POPULATION = {"compact": {"id": 1, "alpha_N_per_mm2": 500.0, "c1_N_per_mm2": 16.0, "mu": 0.4},
              "trabecular": {"id": 2, "alpha_N_per_mm2": 200.0, "c1_N_per_mm2": 6.0, "mu": 0.3}}
KEYS = {"alpha_N_per_mm2": "alpha", "c1_N_per_mm2": "c1", "mu": "mu"}


def run(*args):
    p = subprocess.run([str(a) for a in args], capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"make.py: {' '.join(map(str, args[:2]))} failed:\n{p.stdout}{p.stderr}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("burrbench")
    ap.add_argument("outdir")
    ap.add_argument("--specimens", type=int, default=4)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--spread", type=float, default=0.1, help="SD of ln θ across specimens")
    ap.add_argument("--starts", type=int, default=4, help="multistart points per calibration")
    ap.add_argument("--profiles", action="store_true", help="profile likelihoods in every fit (slower)")
    a = ap.parse_args()
    if not 1 <= a.specimens <= 500:
        sys.exit("make.py: --specimens: expected 1..500")
    out = Path(a.outdir)
    out.mkdir(parents=True, exist_ok=True)
    rng = random.Random(a.seed)
    truth = {"spread_ln": a.spread, "seed": a.seed, "population_geometric_mean": {}, "specimens": {}}
    for cls, vals in POPULATION.items():
        truth["population_geometric_mean"][cls] = {KEYS[k]: v for k, v in vals.items() if k in KEYS}
    lines = ['format = "burrbench.study"', 'format_version = "1.0"', f'name = "example study ({a.specimens} specimens)"',
             f'description = "synthetic specimens from a log-normal population, spread {a.spread} in ln, seed {a.seed}"',
             'criteria = "criteria.toml"', "", "[fit]", f"starts = {a.starts}",
             f"profiles = {'true' if a.profiles else 'false'}", "cross_validation = false",
             "discretization_check = false", ""]
    shutil.copy(HERE.parent / "criteria" / "release.toml", out / "criteria.toml")
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
        run(a.burrbench, "sample", "synth", "--extent-mm", 8, 8, 3, "--voxel-mm", 0.1, "--compact-mm", 1.0,
            "--seed", seed, "--out", d / "sample.h5", "--overwrite")
        for k, (rec, lag) in enumerate((("plunge", 0), ("sweep", 2), ("polish", 2))):
            run(a.burrbench, "synth", "--sample", d / "sample.h5", "--protocol", PROTOCOLS / f"{rec}.toml",
                "--params", d / "params_true.toml", "--out", d / f"{rec}.h5", "--truth", d / f"{rec}.truth.json",
                "--noise-N", 0.02,
                "--bias-N", "0.05,-0.03,0.1", "--lag-ms", lag, "--seed", seed + k + 1, "--overwrite")
        lines += ["[[specimen]]", f'id = "{sid}"', f'experiment = "{sid}/experiment.toml"', ""]
    (out / "study.toml").write_text("\n".join(lines))
    (out / "population_truth.json").write_text(json.dumps(truth, indent=1) + "\n")
    print(f"study ready: {out / 'study.toml'} ({a.specimens} specimens)")


if __name__ == "__main__":
    main()
