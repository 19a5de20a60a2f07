"""DICOM series through GDCM (`burrbench sample export-ct` / `sample import --ct`), checked
against files no one here wrote: the DICOM test data shipped in Debian's python3-pydicom,
read independently by pydicom (and Pillow/OpenJPEG for JPEG 2000). Compares pixel values
(after RescaleSlope/Intercept), spacing and position; series assembled by the test in
shuffled file order; malformed files → one line, exit 2."""
import copy
import json
import os
import pathlib
import random
import shutil
import subprocess
import warnings

import h5py
import numpy as np
import pytest

pydicom = pytest.importorskip("pydicom")
from pydicom.uid import generate_uid  # noqa: E402

from bad_input import assert_refused  # noqa: E402
from fixtures_volumes import read_nrrd  # noqa: E402

BURRBENCH = os.environ["BURRBENCH"]
DATA = pathlib.Path(pydicom.__file__).parent / "data" / "test_files"


def run(*args):
    return subprocess.run([BURRBENCH, *map(str, args)], capture_output=True, text=True, timeout=300)


def export(tmp_path, *inputs, extra=(), name="ct.nrrd"):
    """Exports through burrbench → (values zyx, spacing xyz, origin xyz, burrbench_source)."""
    out = tmp_path / name
    r = run("sample", "export-ct", "--ct", *inputs, "--out", out, *extra)
    assert r.returncode == 0, r.stderr
    arr, fields = read_nrrd(out)
    dirs = [list(map(float, d.strip("()").split(","))) for d in fields["space directions"].split()]
    spacing = np.array([dirs[0][0], dirs[1][1], dirs[2][2]])
    origin = np.array(list(map(float, fields["space origin"].strip("()").split(","))))
    kv = {}
    for line in open(out, "rb").read().split(b"\n\n", 1)[0].decode().splitlines():
        if ":=" in line:
            k, v = line.split(":=", 1)
            kv[k] = v
    return arr.astype(np.float64), spacing, origin, json.loads(kv["burrbench_source"])


def read_pydicom(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = pydicom.dcmread(str(path))
        arr = ds.pixel_array.astype(np.float64)
    slope = float(ds.get("RescaleSlope", 1) or 1)
    intercept = float(ds.get("RescaleIntercept", 0) or 0)
    return ds, arr * slope + intercept


# --- single files against pydicom -------------------------------------------------------

def test_ct_small_matches_pydicom(tmp_path):
    ds, want = read_pydicom(DATA / "CT_small.dcm")
    got, spacing, origin, src = export(tmp_path, DATA / "CT_small.dcm")
    assert got.shape == (1, ds.Rows, ds.Columns)
    np.testing.assert_array_equal(got[0], want)            # RescaleIntercept −1024 applied
    assert float(ds.RescaleIntercept) == -1024
    np.testing.assert_allclose(spacing, [float(ds.PixelSpacing[1]), float(ds.PixelSpacing[0]),
                                         float(ds.SpacingBetweenSlices)], rtol=1e-12)
    np.testing.assert_allclose(origin, [float(v) for v in ds.ImagePositionPatient], rtol=1e-12)
    assert src["format"] == "DICOM" and src["series_uid"] == ds.SeriesInstanceUID
    assert src["rescale"] == [{"slope": 1.0, "intercept": -1024.0}]


MR_VARIANTS = ["MR_small.dcm", "MR_small_implicit.dcm", "MR_small_bigendian.dcm", "MR_small_expb.dcm",
               "MR_small_RLE.dcm", "MR_small_jp2klossless.dcm", "MR_small_jpeg_ls_lossless.dcm",
               "MR_small_padded.dcm"]


@pytest.mark.parametrize("name", MR_VARIANTS)
def test_mr_small_transfer_syntaxes_match_the_uncompressed_file(tmp_path, name):
    """The same image in explicit/implicit little endian, big endian, RLE, lossless JPEG 2000
    and JPEG-LS: every one decodes to pydicom's pixels of the uncompressed MR_small.dcm."""
    ds, want = read_pydicom(DATA / "MR_small.dcm")
    got, spacing, origin, src = export(tmp_path, DATA / name)
    np.testing.assert_array_equal(got[0], want)
    np.testing.assert_allclose(spacing, [0.3125, 0.3125, 0.8], rtol=1e-12)  # PixelSpacing, SliceThickness
    np.testing.assert_allclose(origin, [float(v) for v in ds.ImagePositionPatient], rtol=1e-12)
    if name != "MR_small.dcm":
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ts = pydicom.dcmread(str(DATA / name)).file_meta.TransferSyntaxUID
        assert src["transfer_syntaxes"] == [str(ts)]


def test_lossy_jpeg2000_ct_matches_pillow(tmp_path):
    """693_J2KI.dcm: a 512² CT slice in lossy JPEG 2000 (BitsStored 14, intercept −1024);
    pydicom decodes it through Pillow's OpenJPEG, burrbench through GDCM's."""
    ds, want = read_pydicom(DATA / "693_J2KI.dcm")
    got, spacing, origin, _ = export(tmp_path, DATA / "693_J2KI.dcm")
    diff = np.abs(got[0] - want)
    assert diff.max() <= 1.0, diff.max()
    assert float(ds.RescaleIntercept) == -1024 and got.min() < -900
    np.testing.assert_allclose(spacing, [0.478516, 0.478516, 20.0], rtol=1e-12)  # SpacingBetweenSlices
    np.testing.assert_allclose(origin, [-122.5, -112.4, 47.0], rtol=1e-12)


def test_jpeg2000_without_patient_geometry(tmp_path):
    """JPEG2000.dcm (an NM image without position/orientation): origin 0, axes as stored,
    the slice spacing from --spacing-mm; pixels as pydicom/Pillow decode them."""
    _, want = read_pydicom(DATA / "JPEG2000.dcm")
    got, spacing, origin, src = export(tmp_path, DATA / "JPEG2000.dcm", extra=("--spacing-mm", "2.26,2.26,1"))
    np.testing.assert_array_equal(got[0], want)
    np.testing.assert_allclose(spacing, [2.26, 2.26, 1.0])
    np.testing.assert_allclose(origin, [0, 0, 0])
    assert "origin 0" in src["frame"]


def test_jpeg_extended_12_bit_decodes_like_its_jpeg2000_twin(tmp_path):
    """JPGExtended.dcm (12-bit lossy JPEG, which pydicom here cannot decode) holds the image
    of JPEG2000.dcm: GDCM's decode agrees with it to within the lossy coder's error."""
    _, want = read_pydicom(DATA / "JPEG2000.dcm")
    got, _, _, _ = export(tmp_path, DATA / "JPGExtended.dcm", extra=("--spacing-mm", "2.26,2.26,1"))
    err = np.abs(got[0] - want)
    # Measured: median |difference| 2 grey, 99th percentile 23 (of a 0..264 range); the two
    # lossy codings differ most at sharp edges.
    assert np.median(err) <= 2, np.median(err)
    assert np.percentile(err, 99) <= 30, np.percentile(err, 99)
    assert abs(got[0].mean() - want.mean()) < 1.5


# --- series ------------------------------------------------------------------------------

def test_real_series_in_reverse_file_order(tmp_path):
    """dicomdirtests/98892001/CT5N: five CT slices whose file names run against z. The
    volume runs along +z, each slice as pydicom reads it."""
    folder = DATA / "dicomdirtests" / "98892001" / "CT5N"
    slices = sorted((pydicom.dcmread(str(f)) for f in folder.iterdir()),
                    key=lambda d: float(d.ImagePositionPatient[2]))
    got, spacing, origin, src = export(tmp_path, folder)
    assert got.shape == (5, 16, 16)
    for z, ds in enumerate(slices):
        np.testing.assert_array_equal(got[z], ds.pixel_array * float(ds.RescaleSlope) + float(ds.RescaleIntercept))
    np.testing.assert_allclose(spacing, [0.488281, 0.488281, 2.5], rtol=1e-6)
    np.testing.assert_allclose(origin, [float(v) for v in slices[0].ImagePositionPatient], rtol=1e-9)
    assert src["slices"] == 5


def make_series(folder, n=6, gap=1.25, iop=(1, 0, 0, 0, 1, 0), uid=None, seed=3, shift=None, tilt=0.0):
    """A series made from CT_small.dcm: slice k at position p0 + k·gap·normal (+ a sideways
    `tilt` per slice), pixels + 7k, RescaleIntercept −1024 + 3k, shuffled file names and
    instance numbers. Returns [(file, dataset)] in slice order."""
    folder.mkdir(parents=True, exist_ok=True)
    base = pydicom.dcmread(str(DATA / "CT_small.dcm"))
    base_px = base.pixel_array.astype(np.int16).copy()
    uid = uid or generate_uid()
    r, c = np.array(iop[:3], float), np.array(iop[3:], float)
    normal = np.cross(r, c)
    p0 = np.array([-40.0, 12.5, 30.0])
    rng = random.Random(seed)
    names = [f"IM{i:04d}" for i in range(n)]
    rng.shuffle(names)
    numbers = list(range(1, n + 1))
    rng.shuffle(numbers)
    out = []
    for k in range(n):
        ds = copy.deepcopy(base)
        ds.SeriesInstanceUID = uid
        ds.SOPInstanceUID = generate_uid()
        ds.file_meta.MediaStorageSOPInstanceUID = ds.SOPInstanceUID
        ds.InstanceNumber = numbers[k]
        ds.ImageOrientationPatient = [f"{v:g}" for v in iop]
        along = k * gap + (shift if (shift and k == n // 2) else 0.0)
        pos = p0 + along * normal + k * tilt * r
        ds.ImagePositionPatient = [f"{v:.6f}" for v in pos]
        px = base_px + np.int16(7 * k)
        ds.PixelData = px.tobytes()
        ds.RescaleIntercept = f"{-1024 + 3 * k}"
        path = folder / names[k]
        ds.save_as(str(path), write_like_original=False)
        out.append((path, pydicom.dcmread(str(path))))   # as written
    return out


def world_grid(series):
    """Independent expectation: every pixel's world position from IPP + col·Δc·r + row·Δr·c,
    then the axis-aligned grid those positions fill (origin = smallest corner)."""
    pts, vals = [], []
    for _, ds in series:
        iop = np.array([float(v) for v in ds.ImageOrientationPatient])
        r, c = iop[:3], iop[3:]
        dr, dc = float(ds.PixelSpacing[0]), float(ds.PixelSpacing[1])
        rows, cols = np.mgrid[0:ds.Rows, 0:ds.Columns]
        p = (np.array([float(v) for v in ds.ImagePositionPatient])[None, None, :]
             + cols[..., None] * dc * r + rows[..., None] * dr * c)
        pts.append(p.reshape(-1, 3))
        vals.append((ds.pixel_array.astype(np.float64) * float(ds.RescaleSlope) + float(ds.RescaleIntercept)).ravel())
    pts, vals = np.concatenate(pts), np.concatenate(vals)
    origin = pts.min(axis=0)
    spacing = []
    for a in range(3):
        u = np.unique(np.round(pts[:, a], 6))
        spacing.append(np.median(np.diff(u)))
    spacing = np.array(spacing)
    idx = np.rint((pts - origin) / spacing).astype(int)
    dims = idx.max(axis=0) + 1
    grid = np.full(dims[::-1], np.nan)
    grid[idx[:, 2], idx[:, 1], idx[:, 0]] = vals
    assert not np.isnan(grid).any()
    return grid, spacing, origin


def test_shuffled_series_imports_in_slice_order(tmp_path):
    series = make_series(tmp_path / "s")
    want, wspacing, worigin = world_grid(series)
    got, spacing, origin, src = export(tmp_path, tmp_path / "s")
    np.testing.assert_array_equal(got, want)
    np.testing.assert_allclose(spacing, wspacing, rtol=1e-5)
    np.testing.assert_allclose(origin, worigin, atol=1e-5)
    assert len(src["rescale"]) == 6  # per-slice intercepts applied
    # The same files named one by one, in another shuffled order.
    files = [str(p) for p, _ in series]
    random.Random(9).shuffle(files)
    got2, _, _, _ = export(tmp_path, *files, name="ct2.nrrd")
    np.testing.assert_array_equal(got2, want)


@pytest.mark.parametrize("iop", [(-1, 0, 0, 0, 1, 0), (0, 1, 0, 0, 0, -1), (1, 0, 0, 0, 0, -1)])
def test_oriented_series_fold_into_the_sample_frame(tmp_path, iop):
    """Flipped and sagittal/coronal stacks: the volume's index axes run along +x, +y, +z
    of the patient frame (LPS), origin at the voxel of smallest coordinates."""
    series = make_series(tmp_path / "s", n=4, gap=0.9, iop=iop)
    want, wspacing, worigin = world_grid(series)
    got, spacing, origin, _ = export(tmp_path, tmp_path / "s")
    assert got.shape == want.shape
    np.testing.assert_array_equal(got, want)
    np.testing.assert_allclose(spacing, wspacing, rtol=1e-5)
    np.testing.assert_allclose(origin, worigin, atol=1e-5)


def test_sample_import_from_a_dicom_folder(tmp_path):
    """`sample import --ct FOLDER` segments the series; the sample records its DICOM source
    and hashes every slice."""
    make_series(tmp_path / "s", n=4, gap=0.661468)  # cubic voxels: the gap is the pixel size
    out = tmp_path / "S.h5"
    r = run("sample", "import", "--ct", tmp_path / "s", "--out", out)
    assert r.returncode == 0, r.stderr
    with h5py.File(out, "r") as f:
        seg = json.loads(f["segmentation_json"][()])
        paths = [p.decode() if isinstance(p, bytes) else p for p in f["sources/path"][()]]
    assert seg["ct_source"]["format"] == "DICOM" and seg["ct_source"]["slices"] == 4
    assert len(paths) == 4


def test_several_series_are_listed_then_one_chosen(tmp_path):
    a = make_series(tmp_path / "mix", n=3, uid="1.2.3.4.100", seed=1)
    make_series(tmp_path / "other", n=2, uid="1.2.3.4.200", seed=2)
    for p in (tmp_path / "other").iterdir():
        shutil.move(str(p), tmp_path / "mix" / ("b" + p.name))
    r = run("sample", "export-ct", "--ct", tmp_path / "mix", "--out", tmp_path / "x.nrrd")
    assert_refused(r.returncode, r.stderr, tmp_path / "mix", "SeriesInstanceUID", "1.2.3.4.100 (3 files",
                   "1.2.3.4.200 (2 files", "--dicom-series", label="two series")
    got, _, _, src = export(tmp_path, tmp_path / "mix", extra=("--dicom-series", "1.2.3.4.100"))
    assert got.shape[0] == 3 and src["series_uid"] == "1.2.3.4.100"
    np.testing.assert_array_equal(got, world_grid(a)[0])
    r = run("sample", "export-ct", "--ct", tmp_path / "mix", "--dicom-series", "9.9", "--out", tmp_path / "y.nrrd")
    assert_refused(r.returncode, r.stderr, tmp_path / "mix", "9.9", "1.2.3.4.200", label="unknown series")


# --- refusals ----------------------------------------------------------------------------

def refused_export(tmp_path, inputs, files, *fragments, label=""):
    out = tmp_path / "refused.nrrd"
    r = run("sample", "export-ct", "--ct", *inputs, "--out", out)
    assert_refused(r.returncode, r.stderr, files, *fragments, label=label)
    assert not out.exists()
    r = run("sample", "import", "--ct", *inputs, "--out", tmp_path / "refused.h5")
    assert_refused(r.returncode, r.stderr, files, *fragments, label=label + " (import)")


def test_real_uneven_series_is_refused(tmp_path):
    """dicomdirtests/77654033/CT2: slices at z −99.48, 103.02, 104.27, 105.52."""
    folder = DATA / "dicomdirtests" / "77654033" / "CT2"
    refused_export(tmp_path, [folder], [folder / n for n in os.listdir(folder)], "ImagePositionPatient",
                   "evenly spaced", "gaps from 1.25 to 202.5 mm", label="uneven CT2")


def test_uneven_and_tilted_and_duplicate_series_are_refused(tmp_path):
    s = make_series(tmp_path / "uneven", n=6, gap=1.0, shift=0.2)
    refused_export(tmp_path, [tmp_path / "uneven"], [p for p, _ in s], "evenly spaced", label="uneven")
    s = make_series(tmp_path / "tilt", n=6, gap=1.0, tilt=0.2)   # 0.2 mm sideways per 1 mm: 11.3°
    refused_export(tmp_path, [tmp_path / "tilt"], [p for p, _ in s], "gantry", "11.3°", label="tilted")
    s = make_series(tmp_path / "dup", n=3, gap=1.0)
    shutil.copy(s[1][0], tmp_path / "dup" / "copy")
    refused_export(tmp_path, [tmp_path / "dup"], [tmp_path / "dup" / "copy", s[1][0]], "one slice per position",
                   label="duplicate")


def test_rotated_orientation_is_refused(tmp_path):
    """J2K_pixelrep_mismatch.dcm is an oblique slice (column direction (0, 0.927, −0.375))."""
    f = DATA / "J2K_pixelrep_mismatch.dcm"
    refused_export(tmp_path, [f], f, "ImageOrientationPatient", "axis-aligned", label="oblique")


@pytest.mark.parametrize("name,fragment", [
    ("MR_truncated.dcm", "PixelData"),        # pixel data shorter than Rows × Columns
    ("rtplan.dcm", "PixelData"),              # no image at all
    ("rtplan_truncated.dcm", ""),
    ("SC_rgb.dcm" if (DATA / "SC_rgb.dcm").exists() else "SC_rgb_rle.dcm", "SamplesPerPixel"),
    ("rtdose.dcm", "NumberOfFrames"),         # 15 frames of 32-bit dose
    ("badVR.dcm", ""),
    ("no_meta.dcm", ""),
    ("ExplVR_BigEndNoMeta.dcm", ""),
])
def test_malformed_and_unsupported_files_from_pydicom(tmp_path, name, fragment):
    f = DATA / name
    refused_export(tmp_path, [f], f, *([fragment] if fragment else []), label=name)


def test_files_cut_short_or_not_dicom(tmp_path):
    blob = (DATA / "CT_small.dcm").read_bytes()
    for cut in (100, 700, len(blob) // 2, len(blob) - 1):
        f = tmp_path / f"cut{cut}.dcm"
        f.write_bytes(blob[:cut])
        refused_export(tmp_path, [f], f, label=f"cut at {cut}")
    junk = tmp_path / "junk.dcm"
    junk.write_bytes(b"\0" * 128 + b"DICM" + bytes(random.Random(1).randrange(256) for _ in range(4000)))
    refused_export(tmp_path, [junk], junk, label="junk")
    empty = tmp_path / "empty.dcm"
    empty.write_bytes(b"")
    refused_export(tmp_path, [empty], empty, label="empty")
    # A folder of good slices with one damaged file: refused naming that file.
    s = make_series(tmp_path / "s", n=3)
    s[1][0].write_bytes(s[1][0].read_bytes()[:-4000])
    refused_export(tmp_path, [tmp_path / "s"], s[1][0], label="one damaged slice")


def test_overwrite_never_replaces_a_file_of_the_series_set_aside(tmp_path):
    # Issue 59, D6b: a DICOM folder's other series is opened (to learn its UID) and set
    # aside; its files are inputs all the same, which --out --overwrite never replaces.
    make_series(tmp_path / "mix", n=3, uid="1.2.3.4.100", seed=1)
    make_series(tmp_path / "other", n=2, uid="1.2.3.4.200", seed=2)
    for p in (tmp_path / "other").iterdir():
        shutil.move(str(p), tmp_path / "mix" / ("b" + p.name))
    for name in sorted(os.listdir(tmp_path / "mix")):
        target = tmp_path / "mix" / name
        before = target.read_bytes()
        r = run("sample", "export-ct", "--ct", tmp_path / "mix", "--dicom-series", "1.2.3.4.100", "--out", target,
                "--overwrite")
        assert_refused(r.returncode, r.stderr, target, "not one of the inputs", "--ct", label=f"DICOM {name}")
        assert target.read_bytes() == before
