#!/usr/bin/python3
"""burrbench from Python, in a few lines: replay an experiment, compare the predicted
force with the measured one, and see how a changed friction coefficient moves it.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/quickstart.py \\
        EXPERIMENT.toml PARAMS.toml [--plot force.png]
"""
import argparse

import numpy as np

import burrbench


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("experiment")
    ap.add_argument("params")
    ap.add_argument("--plot", help="write measured vs predicted |F| of the first recording to this PNG")
    a = ap.parse_args()

    pred = burrbench.replay(a.experiment, a.params)
    for rid, rec in pred.items():
        e = rec["force_sensor_meas_N"] - rec["force_sensor_pred_N"]
        e -= e[rec["class_mask"] == 0].mean(axis=0) if (rec["class_mask"] == 0).any() else 0  # tare
        print(f"{rid}: {len(rec['t_s'])} samples, RMS error {np.sqrt((e ** 2).mean()):.4f} "
              f"{rec.units['force_sensor_pred_N']} ({rec.frames['force_sensor_pred_N']} frame)")

    # The same replay with every class's friction coefficient raised by 20 %.
    classes = burrbench.read_params(a.params)["classes"]
    more_mu = {name: {"id": c["id"], "alpha_N_per_mm2": c["alpha_N_per_mm2"],
                      "c1_N_per_mm2": c["c1_N_per_mm2"], "mu": 1.2 * c["mu"]} for name, c in classes.items()}
    pred2 = burrbench.replay(a.experiment, more_mu)
    for rid in pred:
        f1 = np.linalg.norm(pred[rid]["force_sensor_pred_N"], axis=1)
        f2 = np.linalg.norm(pred2[rid]["force_sensor_pred_N"], axis=1)
        print(f"{rid}: peak |F| {f1.max():.3f} N, with mu x1.2 {f2.max():.3f} N")

    if a.plot:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        rid, rec = next(iter(pred.items()))
        fig, ax = plt.subplots(figsize=(8, 3))
        ax.plot(rec["t_s"], np.linalg.norm(rec["force_sensor_meas_N"], axis=1), label="measured", lw=0.8)
        ax.plot(rec["t_s"], np.linalg.norm(rec["force_sensor_pred_N"], axis=1), label="predicted", lw=1.2)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("|F| (N)")
        ax.set_title(rid)
        ax.legend()
        fig.tight_layout()
        fig.savefig(a.plot, dpi=100)
        print(f"wrote {a.plot}")


if __name__ == "__main__":
    main()
