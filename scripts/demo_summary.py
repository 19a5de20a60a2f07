"""Prints the demo's summary, a line each: the report's path; fitted against true constants,
a line per class; the constants limited by discretization error (fit.json's discretization
check); the verification's discretization error in force against the sensor noise (the
validate run's study, prediction.h5 /context); the FIFO records acquisition lost (from
acquire's own warnings in OUT/acquire-*.log); the gate's verdict; the wall time.
Usage: demo_summary.py OUT TRUTH.toml GATE SECONDS"""
import glob
import json
import os
import re
import sys
import tomllib

import h5py


def line(label, text):
    print(f"{label + ':':<12}{text}")


def constants(fit, truth):
    keys = {"alpha": "alpha_N_per_mm2", "c1": "c1_N_per_mm2", "mu": "mu"}
    for name, cls in truth.items():
        parts = []
        for p in fit["parameters"]:
            if p["class_name"] != name:
                continue
            true = cls[keys[p["name"]]]
            if p.get("identifiable") and p.get("estimate") is not None:
                err = 100.0 * (p["estimate"] - true) / true
                parts.append(f"{p['name']} {p['estimate']:.4g} (truth {true:.4g}, {err:+.1f} %)")
            else:
                parts.append(f"{p['name']} not identifiable ({p.get('reason', '')})")
        line(name, "; ".join(parts))


def limited(fit):
    """The constants whose estimate moves by more than half its 95 % interval at 2l."""
    if not fit["settings"].get("discretization_check", {}).get("computed"):
        return "no discretization check in this fit"
    by_class = {}
    for p in fit["parameters"]:
        if (p.get("discretization") or {}).get("limited"):
            by_class.setdefault(p["class_name"], []).append(p["name"])
    if not by_class:
        return "none by discretization error (the refit at twice the voxel moves each by < half its interval)"
    return ("by discretization error: " + "; ".join(f"{c} {', '.join(n)}" for c, n in by_class.items())
            + " (fit.json parameters[].discretization; a finer sample: docs/calibration.md)")


def verification(analysis):
    with h5py.File(f"{analysis}/prediction.h5", "r") as f:
        v = json.loads(bytes(f["context"][()]).decode("utf-8")).get("verification") or {}
    if "largest_error_N" not in v:
        return "not computed"
    err, sigma = v["largest_error_N"], v.get("sigma_N")
    if not isinstance(sigma, (int, float)):
        return f"discretization error in force {err:.3g} N ({v['worst_recording']}); the sensor noise is unknown"
    where = "below" if err < sigma else "above"
    return (f"discretization error in force {err:.3g} N ({v['worst_recording']}) against the sensor noise "
            f"{sigma:.3g} N: ×{err / sigma:.2g}, {where} it (report section 3)")


def lost_records(out):
    lost = {}
    for log in sorted(glob.glob(f"{out}/acquire-*.log")):
        session = os.path.basename(log)[len("acquire-"):-len(".log")]
        for text in open(log, errors="replace"):
            m = re.match(r"warning: (\S+) lost (\d+) of (\d+) FIFO records", text)
            if m:
                lost.setdefault(m.group(1), []).append((session, int(m.group(2)), int(m.group(3))))
    if not lost:
        return "no FIFO record lost in acquisition"
    parts = [f"{dev} {sum(n for _, n, _ in v)} of {sum(t for _, _, t in v)} ("
             + ", ".join(f"{s} {n}" for s, n, _ in v) + ")" for dev, v in lost.items()]
    return ("FIFO records lost in acquisition: " + "; ".join(parts)
            + f" (a loaded host; {out}/acquire-*.log, docs/rig.md)")


def main():
    out, truth_path, gate, seconds = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
    fit = json.load(open(f"{out}/fit/fit.json"))
    line("report", f"{out}/validate/report.html")
    constants(fit, tomllib.load(open(truth_path, "rb"))["classes"])
    line("limited", limited(fit))
    line("verify", verification(f"{out}/validate"))
    line("lost", lost_records(out))
    line("gate", f"{'PASS' if gate == 0 else 'FAIL'} on held-out polish (examples/criteria/release.toml)")
    line("time", f"{seconds} s after the build")


if __name__ == "__main__":
    main()
