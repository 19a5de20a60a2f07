"""Prints the demo's five-line summary: report path, fitted vs true constants per class,
the gate's verdict and the wall time; and a sixth, `warning:` line with the counts when
an acquisition lost FIFO records (from acquire's own warnings in OUT/acquire-*.log).
Usage: demo_summary.py OUT TRUTH.toml GATE SECONDS"""
import glob
import json
import os
import re
import sys
import tomllib

out, truth_path, gate, seconds = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
fit = json.load(open(f"{out}/fit/fit.json"))
truth = tomllib.load(open(truth_path, "rb"))["classes"]
keys = {"alpha": "alpha_N_per_mm2", "c1": "c1_N_per_mm2", "mu": "mu"}

print(f"{'report:':<12}{out}/validate/report.html")
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
    print(f"{name + ':':<12}" + "; ".join(parts))
print(f"{'gate:':<12}{'PASS' if gate == 0 else 'FAIL'} on held-out polish (examples/criteria/release.toml)")
print(f"{'time:':<12}{seconds} s after the build")

lost = {}
for log in sorted(glob.glob(f"{out}/acquire-*.log")):
    session = os.path.basename(log)[len("acquire-"):-len(".log")]
    for line in open(log, errors="replace"):
        m = re.match(r"warning: (\S+) lost (\d+) of (\d+) FIFO records", line)
        if m:
            lost.setdefault(m.group(1), []).append((session, int(m.group(2)), int(m.group(3))))
if lost:
    parts = [f"{dev} {sum(n for _, n, _ in v)} of {sum(t for _, _, t in v)} ("
             + ", ".join(f"{s} {n}" for s, n, _ in v) + ")" for dev, v in lost.items()]
    print(f"{'warning:':<12}FIFO records lost in acquisition: " + "; ".join(parts)
          + f" (a loaded host; {out}/acquire-*.log, docs/rig.md)")
