"""Micro-CT vendors' formats, written by this test from their documented layouts and read
with `burrbench sample export-ct` / `sample import --ct`:
- a Bruker SkyScan (NRecon) reconstruction folder: the `_rec.log` (INI-style keys as NRecon
  writes them) + 8-bit BMP slices (written here byte by byte) or 16-bit TIFF slices;
- a Scanco ISQ file: the 512-byte CTDATA-HEADER_V1 header (little-endian int32 fields at
  the offsets ITK's ScancoImageIO reads) + 16-bit signed data.
Voxel size, values and slice order are checked; a missing or contradictory pixel size is
one line, exit 2."""
import json
import os
import struct
import subprocess

import numpy as np
import pytest

from bad_input import assert_refused
from fixtures_volumes import read_nrrd, write_tiff

BURRBENCH = os.environ["BURRBENCH"]


def run(*args):
    return subprocess.run([BURRBENCH, *map(str, args)], capture_output=True, text=True, timeout=300)


def export(tmp_path, src, extra=()):
    out = tmp_path / "ct.nrrd"
    if out.exists():
        out.unlink()
    r = run("sample", "export-ct", "--ct", src, "--out", out, *extra)
    assert r.returncode == 0, r.stderr
    arr, fields = read_nrrd(out)
    dirs = [list(map(float, d.strip("()").split(","))) for d in fields["space directions"].split()]
    kv = dict(line.split(":=", 1) for line in open(out, "rb").read().split(b"\n\n", 1)[0].decode().splitlines()
              if ":=" in line)
    return arr.astype(np.float64), np.array([dirs[0][0], dirs[1][1], dirs[2][2]]), json.loads(kv["burrbench_source"])


# --- SkyScan ------------------------------------------------------------------------------

def write_bmp8(path, img):
    """An 8-bit BMP (BITMAPINFOHEADER, 256-entry grey palette, rows bottom-up, each padded
    to 4 bytes), as NRecon writes its 8-bit slices."""
    h, w = img.shape
    row = (w + 3) // 4 * 4
    pixels = b"".join(img[y].astype(np.uint8).tobytes() + b"\0" * (row - w) for y in range(h - 1, -1, -1))
    palette = b"".join(bytes((i, i, i, 0)) for i in range(256))
    offset = 14 + 40 + len(palette)
    header = b"BM" + struct.pack("<IHHI", offset + len(pixels), 0, 0, offset)
    info = struct.pack("<IiiHHIIiiII", 40, w, h, 1, 8, 0, len(pixels), 2835, 2835, 256, 256)
    path.write_bytes(header + info + palette + pixels)


LOG = """[System]
Scanner=SkyScan1272
Instrument S/N=14J00000
Camera Pixel Size (um)=  7.40
[User]
User Name=lab
[Acquisition]
Data Directory=D:\\Results\\femur_07
Filename Prefix=femur_07_
Number Of Files=  900
Number Of Rows= 1640
Number Of Columns= 2452
Filename Index Length=8
Camera binning=2x2
Image Pixel Size (um)={image_um}
Scaled Image Pixel Size (um)={image_um}
Image Format=TIFF
Depth (bits)=16
Filter=Al 0.5mm
[Reconstruction]
Reconstruction Program=NRecon
Program Version=Version: 1.7.4.2
Dataset Origin=SkyScan1272
Dataset Prefix=femur_07_
Time and Date=Nov 21, 2022  09:54:51
First Section={first}
Last Section={last}
Section to Section Step={step}
Sections Count={count}
Result File Type={ftype}
Result File Header Length (bytes)=1134
Result Image Width (pixels)={w}
Result Image Height (pixels)={h}
{pixel_line}
Reconstruction Angular Range (deg)=180.40
Undersampling factor={under}
Smoothing=0
Ring Artifact Correction=5
Beam Hardening Correction (%)=30
Minimum for CS to Image Conversion=-0.002500
Maximum for CS to Image Conversion=0.085000
HU Calibration=OFF
BMP LUT=0
[File name convention]
Filename Index Length=8
Filename Prefix=femur_07__rec
"""


def skyscan(folder, slices, pixel_um=9.0, image_um=None, under=1, step=1, first=120, bits=8, pixel_line=None,
            shuffle_write=True):
    folder.mkdir(parents=True)
    nz, h, w = slices.shape
    last = first + step * (nz - 1)
    (folder / "femur_07__rec.log").write_text(LOG.format(
        image_um=image_um if image_um is not None else pixel_um / under, first=first, last=last, step=step, count=nz,
        ftype="BMP" if bits == 8 else "TIF", w=w, h=h, under=under,
        pixel_line=pixel_line if pixel_line is not None else f"Pixel Size (um)={pixel_um:.5f}"), encoding="latin-1")
    order = list(range(nz))[::-1] if shuffle_write else range(nz)   # written last-first: order comes from the numbers
    for z in order:
        name = folder / f"femur_07__rec{first + step * z:08d}.{'bmp' if bits == 8 else 'tif'}"
        if bits == 8:
            write_bmp8(name, slices[z])
        else:
            write_tiff(name, slices[z].astype(np.uint16))
    write_bmp8(folder / "femur_07__spr.bmp", slices[0])   # NRecon's preview image: not a slice
    return [folder / f"femur_07__rec{first + step * z:08d}.{'bmp' if bits == 8 else 'tif'}" for z in range(nz)]


def test_skyscan_8_bit_bmp_folder(tmp_path):
    rng = np.random.default_rng(1)
    slices = rng.integers(0, 256, size=(5, 7, 9)).astype(np.uint8)   # odd width: padded BMP rows
    skyscan(tmp_path / "rec", slices, pixel_um=9.0)
    got, spacing, src = export(tmp_path, tmp_path / "rec")
    np.testing.assert_array_equal(got, slices)
    np.testing.assert_allclose(spacing, [0.009, 0.009, 0.009], rtol=1e-12)
    assert src["format"] == "SkyScan reconstruction" and src["sections"] == [120, 124]
    assert src["attenuation_range"] == [-0.0025, 0.085]
    assert src["attenuation_per_grey"] == pytest.approx(0.0875 / 255)


def test_skyscan_16_bit_tiff_with_undersampling_and_section_step(tmp_path):
    rng = np.random.default_rng(2)
    slices = rng.integers(0, 65536, size=(4, 6, 8)).astype(np.uint16)
    skyscan(tmp_path / "rec", slices, pixel_um=12.5, under=2, step=2, bits=16)
    got, spacing, src = export(tmp_path, tmp_path / "rec")
    np.testing.assert_array_equal(got, slices)
    np.testing.assert_allclose(spacing, [0.0125, 0.0125, 0.025], rtol=1e-12)   # z: pixel × section step
    assert src["attenuation_per_grey"] == pytest.approx(0.0875 / 65535)


def test_skyscan_import_to_a_sample(tmp_path):
    slices = np.zeros((6, 8, 8), np.uint8)
    slices[:, 2:6, 2:6] = 200
    skyscan(tmp_path / "rec", slices, pixel_um=10.0)
    out = tmp_path / "S.h5"
    r = run("sample", "import", "--ct", tmp_path / "rec", "--out", out, "--threshold", "100")
    assert r.returncode == 0, r.stderr
    assert "0.01 mm" in r.stdout


@pytest.mark.parametrize("case,kwargs,fragments", [
    ("missing pixel size", dict(pixel_line=""), ["Pixel Size (um)", "missing"]),
    ("contradictory pixel size", dict(pixel_um=9.0, image_um=4.0), ["Image Pixel Size (um)", "contradictory"]),
    ("pixel size not a number", dict(pixel_line="Pixel Size (um)=nine"), ["Pixel Size (um)", "a number"]),
    ("pixel size given twice", dict(pixel_line="Pixel Size (um)=9.0\nPixel Size (um)=9.5"), ["Pixel Size (um)", "one value"]),
])
def test_skyscan_bad_pixel_size(tmp_path, case, kwargs, fragments):
    skyscan(tmp_path / "rec", np.zeros((3, 4, 4), np.uint8), **kwargs)
    log = tmp_path / "rec" / "femur_07__rec.log"
    for verb in (["sample", "export-ct", "--out", tmp_path / "x.nrrd"], ["sample", "import", "--out", tmp_path / "x.h5"]):
        r = run(*verb, "--ct", tmp_path / "rec")
        assert_refused(r.returncode, r.stderr, log, *fragments, label=case)


def test_skyscan_missing_slice_and_wrong_size(tmp_path):
    files = skyscan(tmp_path / "a", np.zeros((4, 4, 4), np.uint8))
    files[2].unlink()
    r = run("sample", "export-ct", "--ct", tmp_path / "a", "--out", tmp_path / "x.nrrd")
    assert_refused(r.returncode, r.stderr, tmp_path / "a", "section 122 missing", label="missing slice")
    files = skyscan(tmp_path / "b", np.zeros((3, 4, 4), np.uint8))
    write_bmp8(files[1], np.zeros((5, 4), np.uint8))
    r = run("sample", "export-ct", "--ct", tmp_path / "b", "--out", tmp_path / "x.nrrd")
    assert_refused(r.returncode, r.stderr, files[1], "image size", label="slice of another size")


# --- Scanco ISQ ---------------------------------------------------------------------------

def write_isq(path, vol, dim_um, increment_um=None, offset_blocks=0, mu_scaling=4096, magic=b"CTDATA-HEADER_V1",
              truncate=0):
    """vol (nz, ny, nx) int16. Header fields (little-endian int32) at Scanco's offsets."""
    nz, ny, nx = vol.shape
    h = bytearray(512)
    h[0:16] = magic
    ints = {16: 3, 20: vol.nbytes, 24: vol.nbytes // 512, 28: 17, 32: 2135,
            44: nx, 48: ny, 52: nz, 56: dim_um[0], 60: dim_um[1], 64: dim_um[2],
            68: round(dim_um[2] / nz), 72: increment_um if increment_um is not None else round(dim_um[2] / nz),
            76: 51234, 80: int(vol.min()), 84: int(vol.max()), 88: mu_scaling, 92: 2048, 96: 1000,
            100: 20480, 104: 10, 108: 300000, 112: 4711, 116: 4, 120: 0, 124: 3, 168: 70000, 172: 114,
            508: offset_blocks}
    for off, val in ints.items():
        struct.pack_into("<i", h, off, val)
    h[128:168] = b"FEMUR_07".ljust(40, b" ")
    blob = bytes(h) + b"\x5a" * (512 * offset_blocks) + vol.astype("<i2").tobytes()
    path.write_bytes(blob[:len(blob) - truncate] if truncate else blob)


def test_isq_header_and_16_bit_data(tmp_path):
    rng = np.random.default_rng(3)
    vol = rng.integers(-2000, 12000, size=(5, 6, 7)).astype(np.int16)
    f = tmp_path / "C0004711.ISQ"
    write_isq(f, vol, dim_um=(7 * 18, 6 * 18, 5 * 18), offset_blocks=2)   # 18 µm voxels, 2 extra header blocks
    got, spacing, src = export(tmp_path, f)
    np.testing.assert_array_equal(got, vol)
    np.testing.assert_allclose(spacing, [0.018, 0.018, 0.018], rtol=1e-12)
    assert src["format"] == "Scanco ISQ" and src["mu_scaling"] == 4096 and src["name"] == "FEMUR_07"
    assert src["header_bytes"] == 3 * 512
    # The VMS-style name with a version suffix is an ISQ too.
    g = tmp_path / "C0004711.ISQ;1"
    g.write_bytes(f.read_bytes())
    got2, _, _ = export(tmp_path, g)
    np.testing.assert_array_equal(got2, vol)


def test_isq_imports_to_a_sample(tmp_path):
    vol = np.zeros((6, 8, 8), np.int16)
    vol[:, 2:6, 2:6] = 8000
    f = tmp_path / "s.isq"
    write_isq(f, vol, dim_um=(8 * 30, 8 * 30, 6 * 30))
    r = run("sample", "import", "--ct", f, "--out", tmp_path / "S.h5", "--threshold", "4000")
    assert r.returncode == 0, r.stderr
    assert "0.03 mm" in r.stdout


@pytest.mark.parametrize("case,kwargs,fragments", [
    ("zero physical size", dict(dim_um=(0, 80, 60)), ["dimx_um", "positive physical size"]),
    ("contradictory slice increment", dict(dim_um=(80, 80, 60), increment_um=25), ["slice_increment_um", "contradictory"]),
    ("truncated data", dict(dim_um=(80, 80, 60), truncate=3), ["data", "bytes"]),
    ("not an ISQ", dict(dim_um=(80, 80, 60), magic=b"CTDATA-HEADER_V2"), ["CTDATA-HEADER_V1"]),
])
def test_isq_refusals(tmp_path, case, kwargs, fragments):
    f = tmp_path / "bad.isq"
    write_isq(f, np.zeros((6, 8, 8), np.int16), **kwargs)
    for verb in (["sample", "export-ct", "--out", tmp_path / "x.nrrd"], ["sample", "import", "--out", tmp_path / "x.h5"]):
        r = run(*verb, "--ct", f)
        assert_refused(r.returncode, r.stderr, f, *fragments, label=case)
    short = tmp_path / "short.isq"
    short.write_bytes(b"CTDATA-HEADER_V1" + b"\0" * 100)
    r = run("sample", "export-ct", "--ct", short, "--out", tmp_path / "x.nrrd")
    assert_refused(r.returncode, r.stderr, short, "512-byte", label="short header")
