"""The C++ writers' files, read with h5py/numpy (an independent reader), and foreign or
broken files written with h5py (an independent writer) refused by `burrbench inspect`.
Fixture values are documented in apps/verb_debug.cpp and recomputed here."""
import json
import math

import h5py
import numpy as np
import pytest

from bad_input import assert_refused
from formats_helpers import assert_rejected, copy, run, write_fixtures


@pytest.fixture(scope="module")
def fx(tmp_path_factory):
    return write_fixtures(tmp_path_factory.mktemp("fixtures"))


def text(v):
    return v.decode() if isinstance(v, bytes) else str(v)


# ------------------------------------------------------------------ C++ → h5py


def test_recording_values_read_with_h5py(fx):
    with h5py.File(fx / "recording.h5", "r") as f:
        assert text(f.attrs["format"]) == "burrbench.recording"
        assert text(f.attrs["format_version"]) == "1.1"
        m = f["meta"]
        assert text(m.attrs["sample_id"]) == "S1"
        assert text(m.attrs["rig_id"]) == "fixture-rig"
        assert m.attrs["burr_radius_mm"] == 1.5
        np.testing.assert_array_equal(m.attrs["burr_axis_rig"], [0, 0, 1])
        assert m.attrs["spin_sign"] == -1
        assert m.attrs["session_wall_ns"] == 1790000000000000000
        cal = m["sensor_calibration"][()]
        assert cal.shape == (6, 6)
        np.testing.assert_array_equal(cal, np.add.outer(np.arange(6.0), 0.5 * np.arange(6.0)))
        np.testing.assert_array_equal(m["bias"][()], [0.1, -0.2, 0.3, 1, 2, 3])
        assert text(m["register_map_toml"][()]) == '[device]\nname = "fixture"\n'

        ft = f["streams/ft_sensor"]
        i = np.arange(1200)
        t = 1_000_000 + i * 1_000_000
        assert ft["t_ns"].dtype == np.int64
        np.testing.assert_array_equal(ft["t_ns"][()], t)
        np.testing.assert_array_equal(ft["t_send_ns"][()], t - 200_000)
        np.testing.assert_array_equal(ft["t_recv_ns"][()], t + 200_000)
        raw = ft["raw_registers"]
        assert raw.dtype == np.uint16 and raw.shape == (1200, 12)
        assert raw.compression == "gzip" and raw.chunks is not None
        np.testing.assert_array_equal(raw[()], ((12 * i[:, None] + np.arange(12)) % 65536).astype(np.uint16))
        np.testing.assert_array_equal(ft["device_counter"][()], 10 + i)
        np.testing.assert_array_equal(ft["stale"][()], (i % 100 == 99).astype(np.uint8))
        force = ft["channels/force_N"]
        assert text(force.attrs["unit"]) == "N" and force.shape == (1200, 3)
        expect = np.stack([np.sin(0.01 * i), np.cos(0.01 * i), -0.5 + 0.001 * i], axis=1)
        got = force[()]
        assert math.isnan(got[99, 0]) and np.isnan(got).sum() == 1  # NaN only on the stale row
        got[99, 0] = expect[99, 0]
        np.testing.assert_array_equal(got[:, 2], expect[:, 2])  # bit-exact
        # sin/cos: numpy's vectorised sin/cos and libm's differ by a few ulp.
        np.testing.assert_allclose(got[:, :2], expect[:, :2], rtol=0, atol=2e-15)
        np.testing.assert_array_equal(ft["channels/torque_Nmm"][()], np.stack([i, -i, 0.5 * i], axis=1))
        assert text(ft["channels/torque_Nmm"].attrs["unit"]) == "N*mm"

        st = f["streams/stage"]
        j = np.arange(600)
        np.testing.assert_array_equal(st["t_ns"][()], 1_000_000 + 2_000_000 * j)
        np.testing.assert_array_equal(st["channels/position_mm"][()],
                                      np.stack([0.01 * j, -0.02 * j, 5 - 0.001 * j], axis=1))
        assert "raw_registers" not in st
        sp = f["streams/spindle/channels/spindle_rpm"]
        assert sp.shape == (60,) and text(sp.attrs["unit"]) == "rpm"
        np.testing.assert_array_equal(sp[()], 30000 + np.arange(60))

        ev = f["events"]
        np.testing.assert_array_equal(ev["t_ns"][()], [1_000_000, 1_500_000, 1_200_000_000])
        assert [text(k) for k in ev["kind"][()]] == ["start", "tare", "stop"]
        assert [text(k) for k in ev["stream"][()]] == ["", "ft_sensor", ""]
        assert text(ev["detail"][1]) == "bias taken"
        assert text(f["provenance"].attrs["software_version"]).startswith("burrbench")
        assert "write-fixtures" in text(f["provenance"].attrs["command_line"])


@pytest.mark.parametrize("name,counter", [("sample.h5", False), ("sample_counter255.h5", True)])
def test_sample_values_read_with_h5py(fx, name, counter):
    z, y, x = np.meshgrid(np.arange(3), np.arange(5), np.arange(7), indexing="ij")
    labels = np.where(z == 0, 1, np.where((z == 1) & ((x + y) % 2 == 0), 2, 0)).astype(np.uint8)
    chi = np.where(labels == 1, 1.0, np.where(labels == 2, (x + 1) / 8.0, 0.0)).astype(np.float32)
    with h5py.File(fx / name, "r") as f:
        assert text(f.attrs["format"]) == "burrbench.sample"
        assert f.attrs["voxel_size_mm"] == 0.25
        np.testing.assert_array_equal(f.attrs["origin_mm"], [-1.0, 2.0, 0.5])
        assert f["labels"].shape == (3, 5, 7) and f["labels"].dtype == np.uint8  # [nz][ny][nx]
        np.testing.assert_array_equal(f["labels"][()], labels)
        frac = f["fraction"]
        if counter:
            assert text(frac.attrs["encoding"]) == "counter255" and frac.dtype == np.uint8
            np.testing.assert_array_equal(frac[()], np.round(chi.astype(np.float64) * 255).astype(np.uint8))
        else:
            assert text(frac.attrs["encoding"]) == "float32" and frac.dtype == np.float32
            np.testing.assert_array_equal(frac[()], chi)
        assert list(f["classes/id"][()]) == [1, 2]
        assert [text(n) for n in f["classes/name"][()]] == ["compact", "trabecular"]
        assert json.loads(text(f["segmentation_json"][()])) == {"threshold": 1000}
        assert text(f["sources/path"][0]) == "ct.nrrd"
        assert len(text(f["sources/sha256"][0])) == 64


def test_inspect_accepts_every_fixture(fx):
    for name, words in [("recording.h5", ["stream ft_sensor: 1200 samples", "1000 Hz", "12 stale"]),
                        ("sample.h5", ["dims 7×5×3", "class 1 compact: 35 voxels", "class 2 trabecular: 18 voxels"]),
                        ("params.toml", ["compact", "inf"]),
                        ("experiment.toml", ["recording plunge", "class compact (id 1)"]),
                        ("fit.json", ["NOT identifiable", f"{'plunge':<12} {'lag':<12} = 1.5 ± "])]:
        rc, out, err = run("inspect", fx / name)
        assert rc == 0, err
        assert out.rstrip().endswith("valid")
        for w in words:
            assert w in out, (name, w, out)


# ------------------------------------------------------------------ h5py → C++ (foreign and broken files)


def edit(src, dst, fn):
    copy(src, dst)
    with h5py.File(dst, "r+") as f:
        fn(f)
    return dst


def replace(f, path, data, **kw):
    attrs = dict(f[path].attrs)
    del f[path]
    f.create_dataset(path, data=data, **kw)
    for k, v in attrs.items():
        f[path].attrs[k] = v


def test_matlab_style_fixed_length_strings_are_read(fx, tmp_path):
    def fixed(f):
        f["meta"].attrs["notes"] = np.bytes_("written by MATLAB")  # fixed-length, not vlen
        f.attrs["format_version"] = np.bytes_("1.3")  # newer minor: accepted
    p = edit(fx / "recording.h5", tmp_path / "m.h5", fixed)
    rc, out, err = run("inspect", p)
    assert rc == 0, err


def test_a_recording_1_0_states_no_burr_axis_or_spin(fx, tmp_path):
    # 1.0 writers wrote [0, 0, 1] and +1 whether the rig knew them or not: read as not stated.
    p = edit(fx / "recording.h5", tmp_path / "old.h5", lambda f: f.attrs.__setitem__("format_version", np.bytes_("1.0")))
    rc, out, err = run("inspect", p)
    assert rc == 0 and "axis_rig not stated, spin not stated" in out, out + err
    rc, out, err = run("inspect", fx / "recording.h5")
    assert rc == 0 and "axis_rig [0, 0, 1], spin -1" in out, out + err


def test_unknown_major_version(fx, tmp_path):
    p = edit(fx / "recording.h5", tmp_path / "R.h5", lambda f: f.attrs.__setitem__("format_version", "2.0"))
    assert_rejected(p, "R.h5: /@format_version: expected version \"1.x\"", "unknown major version")
    p = edit(fx / "sample.h5", tmp_path / "S.h5", lambda f: f.attrs.__setitem__("format_version", "0.9"))
    assert_rejected(p, "S.h5: /@format_version")


def test_wrong_dataset_type_and_length(fx, tmp_path):
    p = edit(fx / "recording.h5", tmp_path / "R1.h5",
             lambda f: replace(f, "streams/ft_sensor/t_ns", f["streams/ft_sensor/t_ns"][()].astype(np.float64)))
    assert_rejected(p, "R1.h5: /streams/ft_sensor/t_ns: expected int64 dataset, got float64")
    p = edit(fx / "recording.h5", tmp_path / "R2.h5",
             lambda f: replace(f, "streams/ft_sensor/t_send_ns", f["streams/ft_sensor/t_send_ns"][:-1]))
    assert_rejected(p, "R2.h5: /streams/ft_sensor/t_send_ns: expected int64 dataset of length 1200, got 1199")
    p = edit(fx / "recording.h5", tmp_path / "R3.h5",
             lambda f: replace(f, "streams/ft_sensor/channels/force_N", f["streams/ft_sensor/channels/force_N"][:, :2]))
    assert_rejected(p, "R3.h5: /streams/ft_sensor/channels/force_N: expected width 3")
    p = edit(fx / "recording.h5", tmp_path / "R4.h5",
             lambda f: replace(f, "streams/ft_sensor/channels/force_N", f["streams/ft_sensor/channels/force_N"][:10]))
    assert_rejected(p, "R4.h5: /streams/ft_sensor/channels/force_N: expected float64 dataset of shape [1200]")
    p = edit(fx / "sample.h5", tmp_path / "S1.h5", lambda f: replace(f, "labels", f["labels"][0]))
    assert_rejected(p, "S1.h5: /labels: expected a 3-D uint8 dataset [nz][ny][nx], got rank 2")
    p = edit(fx / "sample.h5", tmp_path / "S2.h5", lambda f: replace(f, "labels", f["labels"][()].astype(np.int16)))
    assert_rejected(p, "S2.h5: /labels: expected uint8 dataset, got int16")
    p = edit(fx / "sample.h5", tmp_path / "S3.h5", lambda f: replace(f, "fraction", f["fraction"][:, :, :6]))
    assert_rejected(p, "S3.h5: /fraction: expected the shape of /labels [3×5×7], got [3×5×6]")


def test_nan_inf_and_range(fx, tmp_path):
    def nan_pos(f):
        f["streams/stage/channels/position_mm"][10, 2] = np.nan
    assert_rejected(edit(fx / "recording.h5", tmp_path / "P.h5", nan_pos),
                    "P.h5: /streams/stage/channels/position_mm[10][2]: expected a finite position, got nan")

    def inf_force(f):
        f["streams/ft_sensor/channels/force_N"][5, 1] = np.inf
    assert_rejected(edit(fx / "recording.h5", tmp_path / "F.h5", inf_force),
                    "/streams/ft_sensor/channels/force_N[5][1]", "NaN only on rows flagged stale")

    def backwards(f):
        f["streams/stage/t_ns"][7] = 0
    assert_rejected(edit(fx / "recording.h5", tmp_path / "T.h5", backwards),
                    "/streams/stage/t_ns[7]: expected non-decreasing timestamps")

    def chi(f):
        f["fraction"][0, 1, 2] = 1.5
    assert_rejected(edit(fx / "sample.h5", tmp_path / "C.h5", chi),
                    "C.h5: /fraction[z=0][y=1][x=2]: expected a bone fraction in [0, 1], got 1.5")

    def label(f):
        f["labels"][2, 0, 0] = 9
    assert_rejected(edit(fx / "sample.h5", tmp_path / "L.h5", label),
                    "L.h5: /labels[z=2][y=0][x=0]: expected 0 or a label of the class table, got 9")


def test_unknown_members_rejected(fx, tmp_path):
    p = edit(fx / "recording.h5", tmp_path / "U.h5", lambda f: f.create_dataset("streams/stage/velocity", data=[1.0]))
    assert_rejected(p, "U.h5: /streams/stage/velocity: expected only known members here", "unknown member")


def test_huge_claimed_size_refused_before_allocating(fx, tmp_path):
    def huge(f):
        for name in ("labels", "fraction"):
            attrs = dict(f[name].attrs)
            del f[name]
            # 2^36 voxels claimed, nothing written: the file stays tiny.
            f.create_dataset(name, shape=(4096, 4096, 4096), dtype=np.uint8 if name == "labels" else np.float32,
                             chunks=(16, 64, 64))
            for k, v in attrs.items():
                f[name].attrs[k] = v
    p = edit(fx / "sample.h5", tmp_path / "H.h5", huge)
    assert p.stat().st_size < 1_000_000
    assert_rejected(p, "H.h5: /labels: expected at most 858993459 voxels (4 GiB memory budget), got 4096×4096×4096")


def test_huge_declared_strings_refused_before_allocating(fx, tmp_path):
    # Issue 12: fixed-length strings declared at 1 GiB, nothing stored (a 13 KB file), were
    # allocated before any size check: 3-4 GB. Now refused by their declared size.
    def huge_string(f):
        del f["segmentation_json"]
        t = h5py.h5t.C_S1.copy()
        t.set_size(2**30)
        dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
        dcpl.set_fill_time(h5py.h5d.FILL_TIME_NEVER)
        h5py.h5d.create(f.id, b"segmentation_json", t, h5py.h5s.create(h5py.h5s.SCALAR), dcpl=dcpl)

    def huge_list(f):
        names = f["classes/name"]
        n = names.shape[0]
        del f["classes/name"]
        t = h5py.h5t.C_S1.copy()
        t.set_size(2**29)
        dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
        dcpl.set_fill_time(h5py.h5d.FILL_TIME_NEVER)
        h5py.h5d.create(f.id, b"classes/name", t, h5py.h5s.create_simple((n,)), dcpl=dcpl)
    p = edit(fx / "sample.h5", tmp_path / "HS.h5", huge_string)
    assert p.stat().st_size < 1_000_000
    assert_rejected(p, "HS.h5: /segmentation_json: expected strings of at most", "1 string of 1073741824 bytes declared")
    p = edit(fx / "sample.h5", tmp_path / "HL.h5", huge_list)
    assert_rejected(p, "HL.h5: /classes/name: expected strings of at most 67108864 bytes in all",
                    "strings of 536870912 bytes declared")


def test_truncated_and_foreign_files(fx, tmp_path):
    data = (fx / "recording.h5").read_bytes()
    for frac in (0.95, 0.5, 0.05):
        p = tmp_path / f"cut{int(frac * 100)}.h5"
        p.write_bytes(data[: int(len(data) * frac)])
        assert_rejected(p, str(p) + ": ")
    g = tmp_path / "garbage.h5"
    g.write_bytes(bytes(range(256)) * 8)
    assert_rejected(g, "garbage.h5", "an HDF5, TOML or JSON burrbench file")
    with h5py.File(tmp_path / "other.h5", "w") as f:
        f["x"] = [1, 2, 3]
    assert_rejected(tmp_path / "other.h5", "other.h5: /@format: expected a string attribute, got missing")
    rc, out, err = run("inspect", tmp_path / "absent.h5")
    assert_refused(rc, err, tmp_path / "absent.h5")


def test_huge_recording_refused_before_allocating(fx, tmp_path):
    def huge(f):
        del f["streams/stage/t_ns"]
        f.create_dataset("streams/stage/t_ns", shape=(200_000_000,), dtype=np.int64, chunks=(65536,))
    p = edit(fx / "recording.h5", tmp_path / "HR.h5", huge)
    assert p.stat().st_size < 1_000_000
    assert_rejected(p, "HR.h5: /streams/stage: expected a recording within the 4 GiB memory budget")


@pytest.mark.parametrize("name", ["recording.h5", "sample.h5"])
def test_corrupted_bytes_give_exit_0_or_2_with_one_line(fx, tmp_path, name):
    import random
    rng = random.Random(2026)
    src = (fx / name).read_bytes()
    for i in range(12):
        b = bytearray(src)
        for _ in range(4):
            b[rng.randrange(len(b))] = rng.randrange(256)
        p = tmp_path / f"c{i}.h5"
        p.write_bytes(bytes(b))
        rc, out, err = run("inspect", p)
        assert rc in (0, 2), (i, rc, err)
        if rc == 2:
            assert_refused(rc, err, p, str(p), label=f"c{i}")
        assert p.read_bytes() == bytes(b)
