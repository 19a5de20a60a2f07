"""`burrbench rig sensor-pose` (docs/rig.md "Sensor pose"): the sensor's rotation and
origin from tare files taken under known static loads, written as the manifest's [sensor]
keys. Tare files are made here from a known mounting, as `rig tare` writes them."""
import os
import subprocess
import tomllib

import numpy as np
import pytest

from bad_input import assert_refused

BURRBENCH = os.environ["BURRBENCH"]
G = 9.80665


def rotation(axis, angle):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


Q = rotation([0.2, 1.0, -0.4], 1.3)   # sensor → rig
O = np.array([-4.0, 9.0, 25.0])       # sensor origin, rig frame, mm
BIAS = np.array([0.3, -0.1, 2.0, 15.0, -8.0, 3.0])


def tare(path, wrench):
    v = BIAS + np.concatenate(wrench)
    path.write_text('format = "burrbench.tare"\nformat_version = "1.0"\ndevice = "ft_sensor"\n'
                    f"bias = [{', '.join(repr(float(x)) for x in v)}]\nsamples = 200\nt_monotonic_ns = 1\n")


def reading(f_rig, a_rig):
    f_rig, a_rig = np.asarray(f_rig, float), np.asarray(a_rig, float)
    return Q.T @ f_rig, Q.T @ np.cross(a_rig - O, f_rig)


def make(tmp_path, sideways=True):
    tare(tmp_path / "empty.toml", (np.zeros(3), np.zeros(3)))
    loads = [(0.5, [40, 0, 60]), (0.2, [0, 35, 60]), (1.0, [-25, -15, 50])]
    text = ('format = "burrbench.sensor_loads"\nformat_version = "1.0"\nunloaded = "empty.toml"\n'
            "gravity_rig = [0, 0, -1]\n")
    for i, (m, a) in enumerate(loads):
        tare(tmp_path / f"w{i}.toml", reading([0, 0, -m * G], a))
        text += f'[[loads]]\ntare = "w{i}.toml"\nmass_kg = {m}\npoint_rig_mm = {a}\n'
    if sideways:
        tare(tmp_path / "pull.toml", reading([4.0, 0, 0], [0, 0, 70]))
        text += '[[loads]]\ntare = "pull.toml"\nforce_rig_N = [4.0, 0, 0]\npoint_rig_mm = [0, 0, 70]\n'
    (tmp_path / "loads.toml").write_text(text)
    return tmp_path / "loads.toml"


def run(*args):
    return subprocess.run([BURRBENCH, "rig", "sensor-pose", *map(str, args)], capture_output=True, text=True, timeout=60)


def test_recovers_the_mounting_and_writes_the_manifest_keys(tmp_path):
    loads = make(tmp_path)
    p = run(loads, "--out", tmp_path / "sensor.toml")
    assert p.returncode == 0, p.stdout + p.stderr
    s = tomllib.loads((tmp_path / "sensor.toml").read_text())["sensor"]
    np.testing.assert_allclose(np.asarray(s["rotation_sensor_to_rig"]), Q, atol=1e-9)
    np.testing.assert_allclose(s["origin_rig_mm"], O, atol=1e-6)
    assert "NOT determined" not in p.stdout and "load 3: residual" in p.stdout


def test_hung_weights_alone_say_the_origin_along_gravity_is_open(tmp_path):
    loads = make(tmp_path, sideways=False)
    p = run(loads, "--out", tmp_path / "sensor.toml")
    assert p.returncode == 0, p.stdout + p.stderr
    text = (tmp_path / "sensor.toml").read_text()
    assert "the origin along it is NOT determined" in text
    s = tomllib.loads(text)["sensor"]
    np.testing.assert_allclose(np.asarray(s["rotation_sensor_to_rig"]), Q, atol=1e-9)
    np.testing.assert_allclose(s["origin_rig_mm"][:2], O[:2], atol=1e-6)


def test_bad_loads_are_refused_and_outputs_kept(tmp_path):
    loads = make(tmp_path)
    text = loads.read_text()
    loads.write_text(text.replace("mass_kg = 0.5\n", "mass_kg = 0.5\nforce_rig_N = [0, 0, -1]\n", 1))
    p = run(loads, "--out", tmp_path / "o.toml")
    assert_refused(p.returncode, p.stderr, loads, "loads[0]", "exactly one of mass_kg")
    loads.write_text(text.replace('tare = "w1.toml"', 'tare = "missing.toml"'))
    p = run(loads, "--out", tmp_path / "o.toml")
    assert p.returncode == 2 and "missing.toml" in p.stderr and len(p.stderr.strip().splitlines()) == 1, p.stderr
    loads.write_text(text + "typo = 1\n")
    p = run(loads, "--out", tmp_path / "o.toml")
    assert_refused(p.returncode, p.stderr, loads, "typo")
    assert not (tmp_path / "o.toml").exists()
    loads.write_text(text)
    (tmp_path / "o.toml").write_text("mine")
    p = run(loads, "--out", tmp_path / "o.toml")
    assert_refused(p.returncode, p.stderr, "o.toml", "--overwrite")
    assert (tmp_path / "o.toml").read_text() == "mine"
