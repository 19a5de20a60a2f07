"""Volume importers through the CLI: NRRD / MetaImage / slice-stack fixtures written by an
independent writer (fixtures_volumes.py), imported with `burrbench sample import`, and
read back with h5py: geometry (origin = centre of the first voxel, spacing) and values."""
import hashlib
import json
import os
import subprocess

import h5py
import numpy as np
import pytest

from fixtures_volumes import read_nrrd, write_metaimage, write_nrrd, write_png, write_tiff
from bad_input import assert_refused
from file_size_limit import run_with_file_size_limit

BURRBENCH = os.environ["BURRBENCH"]


def run(*args):
    return subprocess.run([BURRBENCH, *map(str, args)], capture_output=True, text=True, timeout=120)


def sha(p):
    return hashlib.sha256(open(p, "rb").read()).hexdigest()


def load(path):
    with h5py.File(path, "r") as f:
        sources = dict(zip([p.decode() if isinstance(p, bytes) else p for p in f["sources/path"][()]],
                           [h.decode() if isinstance(h, bytes) else h for h in f["sources/sha256"][()]]))
        seg = f["segmentation_json"][()]
        return {"labels": f["labels"][()], "fraction": f["fraction"][()],
                "voxel": float(f.attrs["voxel_size_mm"]), "origin": np.array(f.attrs["origin_mm"]),
                "sources": sources, "seg": json.loads(seg.decode() if isinstance(seg, bytes) else seg)}


def phantom(shape, seed=0):
    rng = np.random.default_rng(seed)
    labels = rng.integers(0, 3, size=shape).astype(np.uint8)
    frac = np.where(labels > 0, rng.uniform(0.05, 1.0, size=shape), 0).astype(np.float32)
    return labels, frac


def test_nrrd_attached_raw(tmp_path):
    labels, frac = phantom((4, 5, 6))
    L, F, out = tmp_path / "L.nrrd", tmp_path / "F.nrrd", tmp_path / "S.h5"
    write_nrrd(L, labels, spacing=(0.2, 0.2, 0.2), origin=(1.5, -2.0, 3.25))
    write_nrrd(F, frac, spacing=(0.2, 0.2, 0.2), origin=(1.5, -2.0, 3.25))
    before = sha(L), sha(F)
    r = run("sample", "import", "--labels", L, "--fraction", F, "--out", out)
    assert r.returncode == 0, r.stderr
    s = load(out)
    np.testing.assert_array_equal(s["labels"], labels)
    np.testing.assert_array_equal(s["fraction"], frac)
    assert s["voxel"] == pytest.approx(0.2)
    np.testing.assert_allclose(s["origin"], [1.5, -2.0, 3.25])
    assert s["sources"] == {str(L): before[0], str(F): before[1]}
    assert (sha(L), sha(F)) == before


def test_nrrd_detached_gzip_big_endian_and_counter_fraction(tmp_path):
    labels, frac = phantom((3, 4, 5), seed=1)
    counter = np.round(frac * 255).astype(np.uint8)
    L, F, out = tmp_path / "L.nhdr", tmp_path / "F.nhdr", tmp_path / "S.h5"
    write_nrrd(L, labels.astype(np.int16), spacing=(0.5,) * 3, origin=(0, 0, -1), encoding="gzip", big=True,
               detached=True, data_suffix=".raw.gz")
    write_nrrd(F, counter, spacing=(0.5,) * 3, origin=(0, 0, -1), detached=True)
    r = run("sample", "import", "--labels", L, "--fraction", F, "--out", out)
    assert r.returncode == 0, r.stderr
    s = load(out)
    np.testing.assert_array_equal(s["labels"], labels)
    np.testing.assert_allclose(s["fraction"], counter / 255.0, atol=1e-7)
    np.testing.assert_allclose(s["origin"], [0, 0, -1])
    # the detached data files are inputs too
    assert str(tmp_path / "L.raw.gz") in s["sources"] and str(tmp_path / "F.raw") in s["sources"]


def test_anisotropic_spacing_resampled_to_cubic(tmp_path):
    nz, ny, nx = 5, 3, 4
    labels = np.zeros((nz, ny, nx), np.uint8)
    labels[2:] = 1
    frac = np.repeat(np.linspace(0.0, 1.0, nz, dtype=np.float32), ny * nx).reshape(nz, ny, nx)
    frac[labels == 0] = 0
    L, F, out = tmp_path / "L.nrrd", tmp_path / "F.nrrd", tmp_path / "S.h5"
    write_nrrd(L, labels, spacing=(0.1, 0.1, 0.3), origin=(2.0, 3.0, 4.0), encoding="gzip")
    write_nrrd(F, frac, spacing=(0.1, 0.1, 0.3), origin=(2.0, 3.0, 4.0), encoding="gzip")
    r = run("sample", "import", "--labels", L, "--fraction", F, "--out", out)
    assert_refused(r.returncode, r.stderr, L, "cubic voxels")
    r = run("sample", "import", "--labels", L, "--fraction", F, "--out", out, "--resample")
    assert r.returncode == 0, r.stderr
    s = load(out)
    assert s["voxel"] == pytest.approx(0.1)
    np.testing.assert_allclose(s["origin"], [2.0, 3.0, 4.0])
    assert s["labels"].shape == (13, 3, 4)  # z span 4 × 0.3 mm = 1.2 mm → 13 centres
    zin = np.arange(13) * 0.1 / 0.3        # output z in input index units
    np.testing.assert_array_equal(s["labels"][:, 0, 0], labels[np.floor(zin + 0.5).astype(int), 0, 0])
    want = np.interp(zin, np.arange(nz), frac[:, 0, 0])
    got = s["fraction"][:, 0, 0]
    lab = s["labels"][:, 0, 0]
    np.testing.assert_allclose(got[lab > 0], want[lab > 0], atol=1e-6)
    assert (got[lab == 0] == 0).all()
    # a chosen voxel size
    r = run("sample", "import", "--labels", L, "--out", tmp_path / "S2.h5", "--voxel-mm", "0.15")
    assert r.returncode == 0, r.stderr
    s2 = load(tmp_path / "S2.h5")
    assert s2["voxel"] == pytest.approx(0.15) and s2["labels"].shape == (9, 2, 3)


def test_flipped_and_permuted_directions_fold_into_data(tmp_path):
    labels, _ = phantom((3, 4, 5), seed=2)  # z, y, x
    L, out = tmp_path / "L.nrrd", tmp_path / "S.h5"
    # index axis 0 runs along −x, axis 1 along +y, axis 2 along +z
    write_nrrd(L, labels, directions=[(-0.5, 0, 0), (0, 0.5, 0), (0, 0, 0.5)], origin=(10.0, 1.0, 2.0))
    r = run("sample", "import", "--labels", L, "--out", out)
    assert r.returncode == 0, r.stderr
    s = load(out)
    np.testing.assert_allclose(s["origin"], [10.0 - 0.5 * 4, 1.0, 2.0])
    np.testing.assert_array_equal(s["labels"], labels[:, :, ::-1])
    # swapping axes: index axis 0 along y, axis 1 along x
    write_nrrd(L, labels, directions=[(0, 0.5, 0), (0.5, 0, 0), (0, 0, 0.5)])
    r = run("sample", "import", "--labels", L, "--out", out, "--overwrite")
    assert r.returncode == 0, r.stderr
    np.testing.assert_array_equal(load(out)["labels"], labels.transpose(0, 2, 1))


@pytest.mark.parametrize("msb,compressed,detached", [(False, False, False), (True, False, True), (False, True, True),
                                                     (True, True, False)])
def test_metaimage(tmp_path, msb, compressed, detached):
    labels, frac = phantom((4, 3, 5), seed=3)
    ext = ".mhd" if detached else ".mha"
    L, F, out = tmp_path / ("L" + ext), tmp_path / ("F" + ext), tmp_path / "S.h5"
    write_metaimage(L, labels.astype(np.uint16), spacing=(0.25,) * 3, offset=(-1, 2, 0.5), msb=msb,
                    compressed=compressed, detached=detached)
    write_metaimage(F, frac, spacing=(0.25,) * 3, offset=(-1, 2, 0.5), msb=msb, compressed=compressed,
                    detached=detached)
    r = run("sample", "import", "--labels", L, "--fraction", F, "--out", out)
    assert r.returncode == 0, r.stderr
    s = load(out)
    np.testing.assert_array_equal(s["labels"], labels)
    np.testing.assert_array_equal(s["fraction"], frac)
    np.testing.assert_allclose(s["origin"], [-1, 2, 0.5])
    assert s["voxel"] == pytest.approx(0.25)


@pytest.mark.parametrize("writer,dtype", [(write_png, np.uint8), (write_tiff, np.uint16), (write_png, np.uint16)])
def test_slice_stack_sorted_by_name(tmp_path, writer, dtype):
    labels, _ = phantom((12, 4, 6), seed=4)
    d = tmp_path / "slices"
    d.mkdir()
    ext = ".png" if writer is write_png else ".tif"
    for z in range(12):  # s1 … s12: natural order, not s1, s10, s11, s12, s2
        writer(d / f"s{z + 1}{ext}", labels[z].astype(dtype))
    out = tmp_path / "S.h5"
    r = run("sample", "import", "--labels", d, "--out", out)
    assert r.returncode == 2 and "--spacing-mm" in r.stderr
    r = run("sample", "import", "--labels", d, "--spacing-mm", "0.2,0.2,0.2", "--out", out)
    assert r.returncode == 0, r.stderr
    s = load(out)
    np.testing.assert_array_equal(s["labels"], labels)
    assert s["voxel"] == pytest.approx(0.2)
    assert len(s["sources"]) == 12


def test_library_warnings_do_not_reach_the_terminal(tmp_path):
    # Issue 12: libpng printed "libpng warning: tEXt: CRC error" lines of its own beside
    # ours. A damaged comment chunk changes no pixel: the stack imports, stderr stays empty.
    labels, _ = phantom((3, 4, 6), seed=6)
    d = tmp_path / "slices"
    d.mkdir()
    for z in range(3):
        write_png(d / f"s{z}.png", labels[z].astype(np.uint8), bad_text_crc=True)
    out = tmp_path / "S.h5"
    r = run("sample", "import", "--labels", d, "--spacing-mm", "0.2,0.2,0.2", "--out", out)
    assert r.returncode == 0 and r.stderr == "", r.stderr
    np.testing.assert_array_equal(load(out)["labels"], labels)


def test_ct_segmentation_through_cli(tmp_path):
    # 24×24×30 voxels of 0.1 mm: air on top, a solid 1 mm slab, plates 1 voxel thick below.
    ct = np.zeros((30, 24, 24), np.int16)
    ct[14:24] = 1000
    for z in range(0, 14):
        ct[z, :, ::4] = 1000   # plates every 4th x
    ct[0:14, ::4, :] = 1000
    noise = np.random.default_rng(5).normal(0, 60, ct.shape)
    ct = (ct + noise).astype(np.int16)
    C, out = tmp_path / "CT.nrrd", tmp_path / "S.h5"
    write_nrrd(C, ct, spacing=(0.1,) * 3, encoding="gzip")
    before = sha(C)
    r = run("sample", "import", "--ct", C, "--out", out, "--empty-grey", "0", "--bone-grey", "1000")
    assert r.returncode == 0, r.stderr
    # Progress on stderr, a line per step (a lab CT takes minutes), then the voxel count.
    lines = r.stderr.splitlines()
    assert all(l.startswith("import: ") for l in lines), r.stderr
    assert [l.split(":")[1].strip() for l in lines[:3]] == ["calibrated", "compact", "write"], r.stderr
    assert lines[0].startswith("import: calibrated: bone where grey ≥ ") and \
        "(Otsu), χ = 0 at grey 0 and 1 at 1000 [" in lines[0], lines[0]
    assert lines[3].startswith(f"import: {24 * 24 * 30} voxels ["), r.stderr
    seg_threshold = load(out)["seg"]["threshold"]
    assert f"grey ≥ {seg_threshold:.6g} (Otsu)" in lines[0], (seg_threshold, lines[0])
    s = load(out)
    lab = s["labels"]
    assert (lab[26:] == 0).mean() > 0.99          # air
    assert (lab[16:22] == 1).mean() > 0.99        # inside the slab: compact
    assert (lab[2:10][ct[2:10] > 500] == 2).mean() > 0.95  # plates: trabecular
    seg = s["seg"]
    assert seg["threshold_method"] == "otsu" and seg["empty_grey_source"] == "given"
    assert seg["bone_grey"] == 1000 and "compact_open_mm" in seg and "bvtv_radius_mm" in seg
    assert s["sources"] == {str(C): before} and sha(C) == before


def test_export_nrrd_roundtrip(tmp_path):
    S = tmp_path / "S.h5"
    r = run("sample", "synth", "--voxel-mm", "0.2", "--extent-mm", "2,3,2", "--seed", "2", "--out", S)
    assert r.returncode == 0, r.stderr
    r = run("sample", "export-nrrd", S, "--out-prefix", tmp_path / "P")
    assert r.returncode == 0, r.stderr
    s = load(S)
    lab, fl = read_nrrd(tmp_path / "P_labels.nrrd")
    fr, ff = read_nrrd(tmp_path / "P_fraction.nrrd")
    np.testing.assert_array_equal(lab, s["labels"])
    np.testing.assert_array_equal(fr, s["fraction"])
    assert fl["space origin"] == "(0.10000000000000001,0.10000000000000001,0.10000000000000001)"
    assert fl["space directions"].startswith("(0.20000000000000001,0,0)")
    # and our importer reads the export back to the same sample
    r = run("sample", "import", "--labels", tmp_path / "P_labels.nrrd", "--fraction", tmp_path / "P_fraction.nrrd",
            "--out", tmp_path / "S2.h5")
    assert r.returncode == 0, r.stderr
    s2 = load(tmp_path / "S2.h5")
    np.testing.assert_array_equal(s2["labels"], s["labels"])
    np.testing.assert_array_equal(s2["fraction"], s["fraction"])
    np.testing.assert_allclose(s2["origin"], s["origin"])


def test_export_nrrd_writes_the_pair_or_neither(tmp_path):
    # A file-size limit between the two files' sizes used to leave P_labels.nrrd without
    # its P_fraction.nrrd: the pair appears together or not at all.
    S = tmp_path / "S.h5"
    assert run("sample", "synth", "--voxel-mm", "0.1", "--extent-mm", "3,3,2", "--porosity", "0.6", "--seed", "3",
               "--out", S).returncode == 0
    whole = tmp_path / "whole"
    whole.mkdir()
    assert run("sample", "export-nrrd", S, "--out-prefix", whole / "P").returncode == 0
    labels, fraction = ((whole / f"P_{n}.nrrd").stat().st_size for n in ("labels", "fraction"))
    assert fraction > labels * 1.5, (labels, fraction)  # else the limit below cannot split them
    out = tmp_path / "out"
    out.mkdir()
    r = run_with_file_size_limit(["sample", "export-nrrd", S, "--out-prefix", out / "P"], (labels + fraction) // 2)
    assert r.returncode == 3, r.stderr
    assert r.stderr.startswith(f"burrbench: error: {out / 'P_fraction.nrrd'}: write failed"), r.stderr
    assert list(out.iterdir()) == []


def test_synth_same_seed_same_contents(tmp_path):
    outs = []
    for name, seed in (("a", 1), ("b", 1), ("c", 2)):
        p = tmp_path / f"{name}.h5"
        r = run("sample", "synth", "--voxel-mm", "0.1", "--extent-mm", "3,3,2", "--compact-mm", "0.5",
                "--porosity", "0.6", "--seed", seed, "--out", p)
        assert r.returncode == 0, r.stderr
        outs.append(load(p))
    a, b, c = outs
    np.testing.assert_array_equal(a["labels"], b["labels"])
    np.testing.assert_array_equal(a["fraction"], b["fraction"])
    assert a["seg"] == b["seg"]
    assert not np.array_equal(a["fraction"], c["fraction"])
    assert a["fraction"].dtype == np.float32
    # compact layer 0.5 mm on top, porous core with the asked porosity
    assert (a["labels"][15:] == 1).all()
    core = a["fraction"][:15]
    assert core.mean() == pytest.approx(0.4, abs=2e-3)
    assert set(np.unique(a["labels"][:15])) == {0, 2}


def test_a_ct_replaced_while_it_is_segmented_leaves_no_sample(tmp_path):
    # The sample would carry the SHA-256 of a scan it was not made of: the import stops,
    # naming the CT, and writes nothing. The CT is replaced (an atomic rename, as an export
    # would) as soon as its first stage is done; 224³ voxels take ≈ 0.7 s more here, a
    # margin against a slow reader of the pipe.
    n = 224
    rng = np.random.default_rng(2)
    ct = np.where(rng.random((n, n, n)) < 0.4, 1000, 0).astype(np.int16)
    ct[: n // 4] = 1000
    C, other, out = tmp_path / "CT.nrrd", tmp_path / "CT2.nrrd", tmp_path / "S.h5"
    write_nrrd(C, ct, spacing=(0.05,) * 3)
    ct[0, 0, 0] = 1  # one voxel differs: another export of the scan
    write_nrrd(other, ct, spacing=(0.05,) * 3)
    read = sha(C)
    p = subprocess.Popen([BURRBENCH, "sample", "import", "--ct", str(C), "--out", str(out)], stderr=subprocess.PIPE,
                         text=True)
    lines = []
    for line in p.stderr:
        lines.append(line.rstrip("\n"))
        if line.startswith("import: calibrated"):
            os.replace(other, C)
            break
    lines += p.stderr.read().splitlines()
    assert p.wait(timeout=300) == 2, "\n".join(lines)
    assert lines[-1].startswith(f"burrbench: {C}: file: expected unchanged while import ran (SHA-256 {read[:12]}… "
                                "when read)"), lines[-1]
    assert lines[-1].endswith(f"got changed (now {sha(C)[:12]}…)"), lines[-1]
    assert not out.exists() and sorted(f.name for f in tmp_path.iterdir()) == ["CT.nrrd"]


# --- issue 59, D6b: a file found while reading is an input, never replaced ---------------

def _detached_nrrd(tmp_path):
    labels, _ = phantom((3, 4, 5), seed=7)
    write_nrrd(tmp_path / "det.nhdr", labels, spacing=(0.2,) * 3, detached=True)
    return [tmp_path / "det.nhdr"], tmp_path / "det.raw", []


def _detached_metaimage(tmp_path):
    labels, _ = phantom((3, 4, 5), seed=8)
    write_metaimage(tmp_path / "det.mhd", labels, spacing=(0.2,) * 3, detached=True)
    return [tmp_path / "det.mhd"], tmp_path / "det.raw", []


def _slice_stack(tmp_path):
    labels, _ = phantom((4, 3, 5), seed=9)
    d = tmp_path / "stack"
    d.mkdir()
    for z in range(4):
        write_png(d / f"s{z}.png", labels[z])
    return [d], d / "s2.png", ["--spacing-mm", "0.2,0.2,0.2"]


@pytest.mark.parametrize("make", [_detached_nrrd, _detached_metaimage, _slice_stack], ids=["nhdr data file",
                                                                                        "mhd ElementDataFile",
                                                                                        "stack slice"])
@pytest.mark.parametrize("option", ["--labels", "--fraction", "--ct"])
def test_overwrite_never_replaces_a_file_the_reader_found(tmp_path, make, option):
    # `sample import --labels det.nhdr --out det.raw --overwrite` replaced the header's data
    # file with the sample (exit 0); so did a .mhd's ElementDataFile and a stack's slice.
    given, found, extra = make(tmp_path)
    snapshot = {p: sha(p) for p in tmp_path.rglob("*") if p.is_file()}
    if option == "--fraction":  # the labels from elsewhere; the fraction volume holds the data file
        labels, _ = phantom((3, 4, 5) if given[0].is_file() else (4, 3, 5), seed=7)
        write_nrrd(tmp_path / "L.nrrd", labels, spacing=(0.2,) * 3)
        snapshot[tmp_path / "L.nrrd"] = sha(tmp_path / "L.nrrd")
        args = ["--labels", tmp_path / "L.nrrd", "--fraction", *given]
    else:
        args = [option, *given]
    r = run("sample", "import", *args, *extra, "--out", found, "--overwrite")
    assert_refused(r.returncode, r.stderr, found, "--out", "not one of the inputs", "not even with --overwrite",
                   str(given[0]), label=f"{option} {found.name}")
    assert {p: sha(p) for p in snapshot} == snapshot, "no input changed"
    assert sorted(p for p in tmp_path.rglob("*") if p.is_file()) == sorted(snapshot), "nothing written"
    # Without --overwrite it is refused as an existing file (the earlier check), before reading.
    r = run("sample", "import", *args, *extra, "--out", found)
    assert r.returncode == 2 and "--overwrite" in r.stderr
    # The same file through another spelling and through a hard link is the same input.
    other = tmp_path / "other"
    other.mkdir()
    os.link(found, other / "link")
    for out in (other / ".." / found.relative_to(tmp_path), other / "link"):
        r = run("sample", "import", *args, *extra, "--out", out, "--overwrite")
        assert_refused(r.returncode, r.stderr, out, "not one of the inputs", label=f"{option} via {out.name}")
    assert {p: sha(p) for p in snapshot} == snapshot


def test_export_ct_never_replaces_the_data_file_it_read(tmp_path):
    given, found, _ = _detached_nrrd(tmp_path)
    before = sha(found)
    r = run("sample", "export-ct", "--ct", *given, "--out", found, "--overwrite")
    assert_refused(r.returncode, r.stderr, found, "not one of the inputs", str(given[0]), label="export-ct data file")
    assert sha(found) == before
    # An output beside it, not read, is written as before.
    r = run("sample", "export-ct", "--ct", *given, "--out", tmp_path / "ct.nrrd")
    assert r.returncode == 0, r.stderr
