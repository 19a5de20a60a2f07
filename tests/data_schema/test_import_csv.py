"""CSV recordings through `burrbench recording import`, with and without a column map;
values read back with h5py."""
import os
import subprocess

import h5py
import numpy as np
import pytest

BURRBENCH = os.environ["BURRBENCH"]


def run(*args):
    return subprocess.run([BURRBENCH, *map(str, args)], capture_output=True, text=True, timeout=60)


def stream(path):
    with h5py.File(path, "r") as f:
        s = f["streams/csv"]
        ch = {k: s["channels"][k][()] for k in s["channels"]}
        return s["t_ns"][()], ch


def test_canonical_header_without_map(tmp_path):
    t = np.arange(50) * 0.001 + 12.0
    rows = np.column_stack([t, np.sin(t), np.cos(t), -t, 0.5 * t, -0.25 * t, t ** 2,
                            t * 10, t * 20, t * 30, np.full_like(t, 60000.0)])
    csv = tmp_path / "R.csv"
    with open(csv, "w") as f:
        f.write("t_s,x_mm,y_mm,z_mm,fx_N,fy_N,fz_N,tx_Nmm,ty_Nmm,tz_Nmm,spindle_rpm\n")
        for r in rows:
            f.write(",".join(repr(float(v)) for v in r) + "\n")
    out = tmp_path / "R.h5"
    r = run("recording", "import", "--csv", csv, "--out", out, "--sample-id", "S7")
    assert r.returncode == 0, r.stderr
    t_ns, ch = stream(out)
    np.testing.assert_array_equal(t_ns, np.round(t * 1e9).astype(np.int64))
    np.testing.assert_array_equal(ch["position_mm"], rows[:, 1:4])
    np.testing.assert_array_equal(ch["force_N"], rows[:, 4:7])
    np.testing.assert_array_equal(ch["torque_Nmm"], rows[:, 7:10])
    np.testing.assert_array_equal(ch["spindle_rpm"].ravel(), rows[:, 10])
    with h5py.File(out, "r") as f:
        assert f["meta"].attrs["sample_id"] in ("S7", b"S7")


def test_minimal_canonical_columns_any_order(tmp_path):
    csv = tmp_path / "R.csv"
    csv.write_text("fz_N,t_s,x_mm,y_mm,z_mm,fx_N,fy_N\n1,0.0,1,2,3,4,5\n2,0.5,1,2,3,4,5\r\n")
    r = run("recording", "import", "--csv", csv, "--out", tmp_path / "R.h5")
    assert r.returncode == 0, r.stderr
    t_ns, ch = stream(tmp_path / "R.h5")
    np.testing.assert_array_equal(t_ns, [0, 500_000_000])
    np.testing.assert_array_equal(ch["force_N"], [[4, 5, 1], [4, 5, 2]])
    assert set(ch) == {"position_mm", "force_N"}


def test_labview_layout_with_map(tmp_path):
    csv = tmp_path / "labview.txt"
    csv.write_text(
        "LabVIEW Measurement\tWriter_Version\t2\n"
        "Operator\tme\n"
        "Time (ms)\tPos X [um]\tPos Y [um]\tPos Z [um]\tLoad X\tLoad Y\tLoad Z\tTorque Z [N*m]\tComment\n"
        "0\t1000\t2000\t-3000\t0,5\t1\t2\t0.001\tok\n"
        "2\t1010\t2000\t-3010\t0,75\t1\t2\t0.002\tok\n"
        "\n"
        "4\t1020\t2000\t-3020\t1,0\t1\t2\t0.003\tok\n")
    # German-locale LabVIEW export: tab-separated, decimal comma, a preamble before the header
    m = tmp_path / "map.toml"
    m.write_text('''format = "burrbench.csv_map"
format_version = "1.0"
delimiter = "\\t"
decimal = ","
header_line = 3
[columns."Time (ms)"]
channel = "t_s"
unit = "ms"
[columns."Pos X [um]"]
channel = "x_mm"
unit = "um"
[columns."Pos Y [um]"]
channel = "y_mm"
unit = "um"
[columns."Pos Z [um]"]
channel = "z_mm"
unit = "um"
offset = 3000.0
[columns."Load X"]
channel = "fx_N"
scale = -2.0
[columns."Load Y"]
channel = "fy_N"
unit = "kN"
[columns."Load Z"]
channel = "fz_N"
''')
    out = tmp_path / "R.h5"
    r = run("recording", "import", "--csv", csv, "--map", m, "--out", out)
    assert r.returncode == 0, r.stderr
    t_ns, ch = stream(out)
    np.testing.assert_array_equal(t_ns, [0, 2_000_000, 4_000_000])
    np.testing.assert_allclose(ch["position_mm"], [[1.0, 2.0, 0.0], [1.01, 2.0, -0.01], [1.02, 2.0, -0.02]], atol=1e-12)
    np.testing.assert_allclose(ch["force_N"], [[-1.0, 1000, 2], [-1.5, 1000, 2], [-2.0, 1000, 2]])
    assert "torque_Nmm" not in ch  # unmapped columns are ignored
    with h5py.File(out, "r") as f:
        paths = [p.decode() if isinstance(p, bytes) else p for p in f["provenance/inputs/path"][()]]
    assert paths == [str(csv), str(m)]


def test_decimal_comma_with_a_detected_comma_delimiter_is_refused(tmp_path):
    # No delimiter in the map and a comma-separated file: "0,5" would become two cells.
    csv = tmp_path / "R.csv"
    csv.write_text("t_s,x_mm,y_mm,z_mm,fx_N,fy_N,fz_N\n0,0,0,0,0,5,1\n")
    m = tmp_path / "map.toml"
    m.write_text('format = "burrbench.csv_map"\nformat_version = "1.0"\ndecimal = ","\n[columns.fx_N]\nchannel = "fx_N"\n')
    out = tmp_path / "R.h5"
    r = run("recording", "import", "--csv", csv, "--map", m, "--out", out)
    assert r.returncode == 2, r.stdout + r.stderr
    assert f"{m}: decimal: expected" in r.stderr and str(csv) in r.stderr, r.stderr
    assert not out.exists()


def test_burr_axis_and_spin_are_stated_on_import(tmp_path):
    # Issue 12: a tilted burr imported as axis [0, 0, 1]; the axis is normalised, a bad one refused.
    csv = tmp_path / "R.csv"
    csv.write_text("t_s,x_mm,y_mm,z_mm,fx_N,fy_N,fz_N\n0.0,1,2,3,4,5,6\n0.001,1,2,3,4,5,6\n")
    out = tmp_path / "R.h5"
    r = run("recording", "import", "--csv", csv, "--out", out, "--burr-axis", "0", "3", "4", "--spin", "-1")
    assert r.returncode == 0, r.stderr
    with h5py.File(out, "r") as f:
        np.testing.assert_allclose(f["meta"].attrs["burr_axis_rig"], [0, 0.6, 0.8], rtol=0, atol=1e-15)
        assert int(f["meta"].attrs["spin_sign"]) == -1
    for args, field in ((["--burr-axis", "0", "0", "0"], "--burr-axis"), (["--spin", "2"], "--spin")):
        r = run("recording", "import", "--csv", csv, "--out", tmp_path / "X.h5", *args)
        assert r.returncode == 2 and field in r.stderr and r.stderr.startswith("burrbench:"), r.stderr
        assert not (tmp_path / "X.h5").exists()


def test_spindle_load_as_torque_or_power(tmp_path):
    # The drive's load (issue 13): a torque column, or a power column in kW through a map;
    # not both.
    t = np.arange(20) * 0.001
    csv = tmp_path / "R.csv"
    rows = np.column_stack([t, t, t, t, t, t, t, np.full_like(t, 30000.0), 0.5 + t])
    csv.write_text("t_s,x_mm,y_mm,z_mm,fx_N,fy_N,fz_N,spindle_rpm,spindle_torque_Nmm\n"
                   + "".join(",".join(repr(float(v)) for v in r) + "\n" for r in rows))
    assert run("recording", "import", "--csv", csv, "--out", tmp_path / "T.h5").returncode == 0
    _, ch = stream(tmp_path / "T.h5")
    np.testing.assert_array_equal(ch["spindle_torque_Nmm"].ravel(), rows[:, 8])
    with h5py.File(tmp_path / "T.h5", "r") as f:
        unit = f["streams/csv/channels/spindle_torque_Nmm"].attrs["unit"]
        assert unit in ("N*mm", b"N*mm")
    csv.write_text("time,x,y,z,fx,fy,fz,rpm,P\n" + "".join(",".join(repr(float(v)) for v in r) + "\n" for r in rows))
    m = tmp_path / "map.toml"
    m.write_text('format = "burrbench.csv_map"\nformat_version = "1.0"\n[columns]\n'
                 + "".join(f'{k} = {{ channel = "{c}" }}\n' for k, c in
                           (("time", "t_s"), ("x", "x_mm"), ("y", "y_mm"), ("z", "z_mm"), ("fx", "fx_N"),
                            ("fy", "fy_N"), ("fz", "fz_N"), ("rpm", "spindle_rpm")))
                 + 'P = { channel = "spindle_power_W", unit = "kW" }\n')
    r = run("recording", "import", "--csv", csv, "--map", m, "--out", tmp_path / "P.h5")
    assert r.returncode == 0, r.stderr
    _, ch = stream(tmp_path / "P.h5")
    np.testing.assert_allclose(ch["spindle_power_W"].ravel(), 1000 * rows[:, 8], rtol=1e-15)
    csv.write_text("t_s,x_mm,y_mm,z_mm,fx_N,fy_N,fz_N,spindle_torque_Nmm,spindle_power_W\n0,0,0,0,0,0,0,1,1\n")
    r = run("recording", "import", "--csv", csv, "--out", tmp_path / "B.h5")
    assert r.returncode == 2 and "not both" in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert not (tmp_path / "B.h5").exists()
