"""The wrench end to end (MODEL.md "Moments", issue 13): `burrbench synth` writes the
sensor's moment and the spindle's load torque from the model, `burrbench replay` predicts
them, and both agree with the closed forms computed here from the replay's own burr-frame
quantities: M = −((p − o) × F + T) for a sensor under the sample, τ_spindle = −T·ω̂; and
∫τ_spindle·|ω| dt is the power spent on cutting, Σ_k α_k·removed_k (energy balance)."""
import json
import os
import subprocess
from pathlib import Path

import h5py
import numpy as np
import pytest

BURRBENCH = os.environ["BURRBENCH"]
SRC = Path(os.environ["BURRBENCH_SOURCE_DIR"])
PROTOCOLS = SRC / "examples" / "protocols"


def run(*args):
    p = subprocess.run([BURRBENCH, *map(str, args)], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, f"{args}\n{p.stdout}{p.stderr}"
    return p


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    d = tmp_path_factory.mktemp("wrench")
    subprocess.run(["sh", str(SRC / "examples/experiments/synthetic/make.sh"), BURRBENCH, str(d)],
                   check=True, capture_output=True, timeout=300)
    for name, extra in (("clean", []),
                        ("offsets", ["--noise-N", "0.02", "--torque-noise-Nmm", "0.05", "--torque-bias-Nmm", "1,-2,0.5",
                                     "--spindle-noise-Nmm", "0.01", "--spindle-idle-Nmm", "2",
                                     "--spindle-viscous-Nmm-per-krpm", "0.1"]),
                        ("noisy", ["--noise-N", "0.02"])):
        run("synth", "--sample", d / "sample.h5", "--protocol", PROTOCOLS / "sweep.toml", "--params",
            d / "params_true.toml", "--out", d / f"{name}.h5", "--truth", d / f"{name}.json", *extra)
    man = (d / "experiment.toml").read_text().split("[[recordings]]")[0]
    man += (f'[[recordings]]\nid = "clean"\npath = "{d / "clean.h5"}"\nsample = "S1"\n'
            '[recordings.registration]\nrotation = [[1,0,0],[0,1,0],[0,0,1]]\ntranslation_mm = [0,0,0]\n')
    (d / "e.toml").write_text(man)
    run("replay", "--experiment", d / "e.toml", "--params", d / "params_true.toml", "--out", d / "p.h5")
    return d


def test_replay_predicts_what_synth_wrote_and_the_closed_forms(sweep):
    d = sweep
    with h5py.File(d / "clean.h5") as r, h5py.File(d / "p.h5") as p:
        g = p["recordings/clean"]
        F, T, c = g["force_burr_vol_N"][()], g["moment_burr_vol_Nmm"][()], g["centre_vol_mm"][()]
        M, tau = g["torque_sensor_pred_Nmm"][()], g["spindle_torque_pred_Nmm"][()]
        assert g["torque_sensor_pred_Nmm"].attrs["unit"].decode() == "N*mm"
        # The recording's channels, measured = truth here (no noise, no offsets).
        np.testing.assert_allclose(g["torque_sensor_meas_Nmm"][()], r["streams/ft_sensor/channels/torque_Nmm"][()])
        np.testing.assert_allclose(g["spindle_torque_meas_Nmm"][()], r["streams/spindle/channels/spindle_torque_Nmm"][()])
        scale = np.abs(M).max()
        assert scale > 1.0  # the lever of the force about the rig origin: N·mm
        assert np.abs(g["torque_sensor_meas_Nmm"][()] - M).max() <= 1e-9 * scale
        assert np.abs(g["spindle_torque_meas_Nmm"][()] - tau).max() <= 1e-9 * np.abs(tau).max()
        rpm = r["streams/spindle/channels/spindle_rpm"][()]
    # Closed forms: identity frames, sensor origin at the rig origin, on the sample.
    np.testing.assert_allclose(M, -(np.cross(c, F) + T), rtol=0, atol=1e-12 * scale)
    truth = json.loads((d / "clean.json").read_text())
    axis = np.asarray(truth["protocol"]["burr_axis_vol"]) * truth["protocol"]["spin_sign"]
    axis /= np.linalg.norm(axis)
    np.testing.assert_allclose(tau, -(T @ axis), rtol=0, atol=1e-12 * np.abs(tau).max())
    assert tau.max() > 0 and (tau >= -1e-12).all()  # cutting always brakes the spin
    # T is the friction couple: small beside the lever, never zero in contact.
    assert 0 < np.abs(T).max() < 0.2 * scale
    # Energy balance: ∫τ|ω|dt (N·mm) = Σ α_k removed_k (N/mm²·mm³), the trapezoid rule on the
    # 1 kHz samples against the replay's sub-steps.
    t = np.arange(len(tau)) / truth["protocol"]["sample_rate_hz"]
    omega = np.abs(rpm.ravel()) * 2 * np.pi / 60
    energy = np.trapezoid(tau * omega, t) if hasattr(np, "trapezoid") else np.trapz(tau * omega, t)
    alpha = {c["name"]: c["alpha_N_per_mm2"] for c in truth["params"]["classes"]}
    spent = sum(alpha[k] * v for k, v in truth["removed_mm3_by_class"].items())
    assert spent > 0
    assert energy == pytest.approx(spent, rel=1e-3)  # measured: 1.2e-5


def test_offsets_and_noise_go_to_their_own_channels(sweep):
    d = sweep
    with h5py.File(d / "clean.h5") as a, h5py.File(d / "offsets.h5") as b, h5py.File(d / "noisy.h5") as n:
        # The force's noise does not depend on the moment and spindle settings (own generator).
        assert b["streams/ft_sensor/channels/force_N"][()].tobytes() == n["streams/ft_sensor/channels/force_N"][()].tobytes()
        dm = b["streams/ft_sensor/channels/torque_Nmm"][()] - a["streams/ft_sensor/channels/torque_Nmm"][()]
        assert np.allclose(dm.mean(axis=0), [1, -2, 0.5], atol=4 * 0.05 / np.sqrt(len(dm)))
        assert np.allclose(dm.std(axis=0), 0.05, rtol=0.08)
        rpm = b["streams/spindle/channels/spindle_rpm"][()].ravel()
        ds = b["streams/spindle/channels/spindle_torque_Nmm"][()].ravel() - a["streams/spindle/channels/spindle_torque_Nmm"][()].ravel()
        expected = 2 + 0.1 * np.abs(rpm) / 1000
        assert np.allclose((ds - expected).mean(), 0, atol=4 * 0.01 / np.sqrt(len(ds)))
        assert (ds - expected).std() == pytest.approx(0.01, rel=0.08)
    truth = json.loads((d / "offsets.json").read_text())
    assert truth["spindle_idle_Nmm"] == 2 and truth["torque_bias_Nmm"] == [1, -2, 0.5]
