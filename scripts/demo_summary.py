"""Prints the demo's five-line summary: report path, fitted vs true constants per class,
the gate's verdict and the wall time. Usage: demo_summary.py OUT TRUTH.toml GATE SECONDS"""
import json
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
