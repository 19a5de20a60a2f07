"""Every bad-input class of the importers: exit code 2, one stderr line naming the file,
the field and what was expected, and the input files left byte-for-byte unchanged."""
import gzip
import hashlib
import os
import re
import subprocess
import zlib

import numpy as np
import pytest

from bad_input import assert_refused
from fixtures_volumes import write_metaimage, write_nrrd, write_png, write_tiff

BURRBENCH = os.environ["BURRBENCH"]
LAB = np.zeros((4, 4, 4), np.uint8)
LAB[2:] = 1


def run(*args):
    return subprocess.run([BURRBENCH, *map(str, args)], capture_output=True, text=True, timeout=60)


def digest(paths):
    return {p: hashlib.sha256(open(p, "rb").read()).hexdigest() for p in paths if os.path.isfile(p)}


def nrrd_header(d, **fields):
    base = {"type": "uint8", "dimension": "3", "sizes": "4 4 4", "encoding": "raw",
            "space directions": "(1,0,0) (0,1,0) (0,0,1)", "space origin": "(0,0,0)"}
    base.update(fields)
    return "NRRD0004\n" + "".join(f"{k}: {v}\n" for k, v in base.items() if v is not None) + "\n"


def raw_nrrd(d, name, header, data):
    p = d / name
    p.write_bytes(header.encode() + data)
    return p


# Each case: (id, builder(tmp) → (argv, files), expected substrings in stderr)
def c_truncated_raw(d):
    p = raw_nrrd(d, "L.nrrd", nrrd_header(d), LAB.tobytes()[:50])
    return ["--labels", p], [p], ["L.nrrd", "data", "64 bytes"]


def c_truncated_gzip(d):
    p = raw_nrrd(d, "L.nrrd", nrrd_header(d, encoding="gzip"), gzip.compress(LAB.tobytes())[:-6])
    return ["--labels", p], [p], ["L.nrrd", "data", "complete gzip/zlib stream", "truncated"]


def c_corrupt_gzip(d):
    blob = bytearray(gzip.compress(LAB.tobytes()))
    blob[12:20] = b"\xff" * 8
    p = raw_nrrd(d, "L.nrrd", nrrd_header(d, encoding="gzip"), bytes(blob))
    return ["--labels", p], [p], ["L.nrrd", "data", "gzip/zlib"]


def c_huge_sizes(d):
    p = raw_nrrd(d, "L.nrrd", nrrd_header(d, sizes="100000 100000 100000"), b"\0" * 64)
    return ["--labels", p], [p], ["L.nrrd", "sizes", "memory budget", "100000x100000x100000"]


def c_huge_sizes_budget(d):
    p = raw_nrrd(d, "L.nrrd", nrrd_header(d, sizes="1024 1024 1024"), b"\0" * 64)
    return ["--labels", p, "--budget-mb", "64"], [p], ["L.nrrd", "sizes", "memory budget"]


def c_wrong_dimension(d):
    p = raw_nrrd(d, "L.nrrd", nrrd_header(d, dimension="2", sizes="8 8"), LAB.tobytes())
    return ["--labels", p], [p], ["L.nrrd", "dimension", "expected 3"]


def c_wrong_type(d):
    p = raw_nrrd(d, "L.nrrd", nrrd_header(d, type="double"), LAB.tobytes() * 8)
    return ["--labels", p], [p], ["L.nrrd", "type", "uint8, int16, uint16, float"]


def c_nan_fraction(d):
    f = np.full((4, 4, 4), 0.5, np.float32)
    f[3, 2, 1] = np.nan
    L = raw_nrrd(d, "L.nrrd", nrrd_header(d), LAB.tobytes())
    F = raw_nrrd(d, "F.nrrd", nrrd_header(d, type="float", endian="little"), f.tobytes())
    return ["--labels", L, "--fraction", F], [L, F], ["F.nrrd", "voxel", "finite"]


def c_inf_fraction(d):
    f = np.full((4, 4, 4), 0.5, np.float32)
    f[0, 0, 0] = np.inf
    L = raw_nrrd(d, "L.nrrd", nrrd_header(d), LAB.tobytes())
    F = raw_nrrd(d, "F.nrrd", nrrd_header(d, type="float", endian="little"), f.tobytes())
    return ["--labels", L, "--fraction", F], [L, F], ["F.nrrd", "finite", "inf"]


def c_rotated(d):
    p = raw_nrrd(d, "L.nrrd", nrrd_header(d, **{"space directions": "(0.7071,0.7071,0) (-0.7071,0.7071,0) (0,0,1)"}),
                 LAB.tobytes())
    return ["--labels", p], [p], ["L.nrrd", "space directions", "axis-aligned"]


def c_missing_data_file(d):
    p = d / "L.nhdr"
    p.write_text(nrrd_header(d).rstrip("\n") + "\ndata file: nowhere.raw\n")
    return ["--labels", p], [p], ["nowhere.raw", "existing regular file"]


def c_bad_magic(d):
    p = d / "L.nrrd"
    p.write_bytes(b"PK\x03\x04 not a nrrd")
    return ["--labels", p], [p], ["L.nrrd", "magic", "NRRD0001..NRRD0005"]


def c_missing_spacing(d):
    p = raw_nrrd(d, "L.nrrd", nrrd_header(d, **{"space directions": None, "space origin": None}), LAB.tobytes())
    return ["--labels", p], [p], ["L.nrrd", "space directions", "voxel spacing"]


def c_unknown_field(d):
    p = raw_nrrd(d, "L.nrrd", nrrd_header(d, frobnicate="1"), LAB.tobytes())
    return ["--labels", p], [p], ["L.nrrd", "frobnicate", "known NRRD field"]


def c_mha_truncated(d):
    p = d / "L.mha"
    write_metaimage(p, LAB)
    blob = p.read_bytes()
    p.write_bytes(blob[:-10])
    return ["--labels", p], [p], ["L.mha", "data", "64 bytes"]


def c_mha_huge(d):
    p = d / "L.mha"
    write_metaimage(p, LAB)
    p.write_bytes(p.read_bytes().replace(b"DimSize = 4 4 4", b"DimSize = 99999 99999 99999"))
    return ["--labels", p], [p], ["L.mha", "DimSize", "memory budget"]


def c_mha_type(d):
    p = d / "L.mha"
    write_metaimage(p, LAB)
    p.write_bytes(p.read_bytes().replace(b"MET_UCHAR", b"MET_DOUBLE"))
    return ["--labels", p], [p], ["L.mha", "ElementType", "MET_UCHAR"]


def c_mha_ndims(d):
    p = d / "L.mha"
    write_metaimage(p, LAB)
    p.write_bytes(p.read_bytes().replace(b"NDims = 3", b"NDims = 4"))
    return ["--labels", p], [p], ["L.mha", "NDims", "expected 3"]


def c_zraw_corrupt(d):
    p = d / "L.mhd"
    write_metaimage(p, LAB, compressed=True, detached=True)
    z = d / "L.zraw"
    z.write_bytes(b"\x78\x9c" + b"\x00garbage" * 3)
    return ["--labels", p], [p, z], ["L.zraw", "data"]


def c_tiff_corrupt(d):
    s = d / "slices"
    s.mkdir()
    for z in range(4):
        write_tiff(s / f"s{z}.tif", LAB[z].astype(np.uint16))
    (s / "s2.tif").write_bytes(b"II*\x00" + b"\xff" * 20)
    return ["--labels", s, "--spacing-mm", "1,1,1"], [s / f"s{z}.tif" for z in range(4)], ["s2.tif", "image"]


def c_multipage_tiff(d):
    # Issue 12: the first page was read and the others vanished without a word.
    s = d / "stack"
    s.mkdir()
    write_tiff(s / "s0.tif", LAB[0])
    write_tiff(s / "s1.tif", LAB[1], pages=3)
    return ["--labels", s, "--spacing-mm", "1,1,1"], [s / "s0.tif", s / "s1.tif"], ["s1.tif", "pages", "3 pages"]


def c_slice_size_mismatch(d):
    s = d / "slices"
    s.mkdir()
    for z in range(4):
        write_png(s / f"s{z}.png", LAB[z] if z != 3 else np.zeros((5, 4), np.uint8))
    return ["--labels", s, "--spacing-mm", "1,1,1"], [s / f"s{z}.png" for z in range(4)], ["s3.png", "image size/type", "4x4 8-bit"]


def c_slice_type_mismatch(d):
    s = d / "slices"
    s.mkdir()
    for z in range(4):
        write_png(s / f"s{z}.png", LAB[z].astype(np.uint16 if z == 1 else np.uint8))
    return ["--labels", s, "--spacing-mm", "1,1,1"], [s / f"s{z}.png" for z in range(4)], ["s1.png", "8-bit", "16-bit"]


def c_label_not_integer(d):
    f = LAB.astype(np.float32)
    f[1, 1, 1] = 1.5
    p = raw_nrrd(d, "L.nrrd", nrrd_header(d, type="float", endian="little"), f.tobytes())
    return ["--labels", p], [p], ["L.nrrd", "voxel (1,1,1)", "integer label 0..255"]


def c_fraction_out_of_range(d):
    f = np.where(LAB > 0, 1.2, 0).astype(np.float32)
    L = raw_nrrd(d, "L.nrrd", nrrd_header(d), LAB.tobytes())
    F = raw_nrrd(d, "F.nrrd", nrrd_header(d, type="float", endian="little"), f.tobytes())
    return ["--labels", L, "--fraction", F], [L, F], ["F.nrrd", "bone fraction in [0, 1]"]


def c_geometry_mismatch(d):
    L = raw_nrrd(d, "L.nrrd", nrrd_header(d), LAB.tobytes())
    F = raw_nrrd(d, "F.nrrd", nrrd_header(d, **{"space origin": "(1,0,0)"}), LAB.tobytes())
    return ["--labels", L, "--fraction", F], [L, F], ["F.nrrd", "geometry", "origin (0,0,0)"]


def c_out_is_input(d):
    L = raw_nrrd(d, "L.nrrd", nrrd_header(d), LAB.tobytes())
    return ["--labels", L, "--out-override", L], [L], ["--out", "different from the input"]


VOLUME_CASES = [c_truncated_raw, c_truncated_gzip, c_corrupt_gzip, c_huge_sizes, c_huge_sizes_budget,
                c_wrong_dimension, c_wrong_type, c_nan_fraction, c_inf_fraction, c_rotated, c_missing_data_file,
                c_bad_magic, c_missing_spacing, c_unknown_field, c_mha_truncated, c_mha_huge, c_mha_type, c_mha_ndims,
                c_zraw_corrupt, c_tiff_corrupt, c_multipage_tiff, c_slice_size_mismatch, c_slice_type_mismatch, c_label_not_integer,
                c_fraction_out_of_range, c_geometry_mismatch, c_out_is_input]


def check(r, expected, files, before, out=None, named=None):
    assert_refused(r.returncode, r.stderr, named or files, *expected)
    assert digest(files) == before
    if out is not None:
        assert not os.path.exists(out)


@pytest.mark.parametrize("case", VOLUME_CASES, ids=lambda c: c.__name__[2:])
def test_volume_bad_input(tmp_path, case):
    args, files, expected = case(tmp_path)
    out = tmp_path / "S.h5"
    if "--out-override" in args:
        i = args.index("--out-override")
        out = args[i + 1]
        args = args[:i]
    before = digest(files)
    assert before or any(os.path.isdir(a) for a in map(str, args))
    r = run("sample", "import", *args, "--out", out)
    check(r, expected, files, before, None if out in map(str, files) or out in files else out,
          # the file named may be one the reader discovered (a .nhdr's data file)
          named=list(files) + [a for a in map(str, args) if os.path.isdir(a)] +
          [tmp_path / e for e in expected if re.fullmatch(r"[\w-]+\.\w+", e)])


def c_csv(d, text, map_text=None):
    p = d / "R.csv"
    p.write_text(text)
    files = [p]
    args = ["--csv", p]
    if map_text is not None:
        m = d / "map.toml"
        m.write_text(map_text)
        files.append(m)
        args += ["--map", m]
    return args, files


HEAD = "t_s,x_mm,y_mm,z_mm,fx_N,fy_N,fz_N\n"
MAP = 'format = "burrbench.csv_map"\nformat_version = "1.0"\n[columns.T]\nchannel = "t_s"\n'
CSV_CASES = [
    ("non_numeric", HEAD + "0,1,2,3,4,5,6\n0.1,1,2,abc,4,5,6\n", None, ["R.csv", "line 3, column 4 (\"z_mm\")", "finite number", "abc"]),
    ("nan", HEAD + "0,1,2,3,4,5,6\n0.1,1,2,3,NaN,5,6\n", None, ["R.csv", "line 3, column 5 (\"fx_N\")", "finite number"]),
    ("inf", HEAD + "0,1,2,3,4,5,inf\n", None, ["R.csv", "line 2, column 7 (\"fz_N\")", "finite number"]),
    ("overflow", HEAD + "0,1,2,3,4,5,1e999\n", None, ["R.csv", "line 2, column 7", "finite number"]),
    ("time_not_increasing", HEAD + "0,1,2,3,4,5,6\n0.2,1,2,3,4,5,6\n0.2,1,2,3,4,5,6\n", None,
     ["R.csv", "line 4, column 1 (\"t_s\")", "strictly increasing"]),
    ("column_count", HEAD + "0,1,2,3,4,5,6\n0.1,1,2,3,4,5\n", None, ["R.csv", "line 3", "7 columns like the header", "got 6"]),
    ("unknown_header", "t_s,x_mm,y_mm,z_mm,fx_N,fy_N,fz_N,temp_C\n0,1,2,3,4,5,6,7\n", None,
     ["R.csv", "column 8 (\"temp_C\")", "canonical name", "--map"]),
    ("missing_channel", "t_s,x_mm,y_mm,z_mm,fx_N,fy_N\n0,1,2,3,4,5\n", None, ["R.csv", "header", "column for fz_N"]),
    ("partial_torque", HEAD.strip() + ",tx_Nmm\n0,1,2,3,4,5,6,7\n", None, ["R.csv", "tx_Nmm, ty_Nmm, tz_Nmm"]),
    ("empty", "", None, ["R.csv", "line 1", "header"]),
    ("no_rows", HEAD, None, ["R.csv", "line 2", "at least one data row"]),
    ("map_unknown_key", "T\n0\n", MAP + 'colour = "red"\n', ["map.toml", "colour", "known key"]),
    ("map_unknown_column_key", "T\n0\n", MAP + 'units = "ms"\n'.replace("units", "[columns.T2]\nchannel = \"x_mm\"\nunits"),
     ["map.toml", "columns.T2.units", "known key"]),
    ("map_bad_channel", "T\n0\n", MAP.replace('"t_s"', '"time"'), ["map.toml", "columns.T.channel", "one of t_s"]),
    ("map_bad_unit", "T\n0\n", MAP + 'unit = "fortnight"\n', ["map.toml", "columns.T.unit", "s, ms, us"]),
    ("map_column_absent", "Time\n0\n", MAP, ["map.toml", "columns.\"T\"", "no such column"]),
    ("map_bad_toml", "T\n0\n", "format = \n", ["map.toml", "line 1", "valid TOML"]),
    ("map_wrong_format", "T\n0\n", MAP.replace("burrbench.csv_map", "burrbench.params"), ["map.toml", "format", "burrbench.csv_map"]),
    ("map_major_version", "T\n0\n", MAP.replace('"1.0"', '"2.0"'), ["map.toml", "format_version", "1.x"]),
]


@pytest.mark.parametrize("name,text,map_text,expected", CSV_CASES, ids=[c[0] for c in CSV_CASES])
def test_csv_bad_input(tmp_path, name, text, map_text, expected):
    args, files = c_csv(tmp_path, text, map_text)
    before = digest(files)
    out = tmp_path / "R.h5"
    r = run("recording", "import", *args, "--out", out)
    check(r, expected, files, before, out)


def test_csv_out_is_input(tmp_path):
    args, files = c_csv(tmp_path, HEAD + "0,1,2,3,4,5,6\n")
    before = digest(files)
    r = run("recording", "import", *args, "--out", files[0])
    check(r, ["--out", "different from the inputs"], files, before)


def test_export_of_corrupt_sample_file(tmp_path):
    p = tmp_path / "S.h5"
    p.write_bytes(b"\x89HDF\r\n\x1a\n" + b"\0" * 100)
    before = digest([p])
    r = run("sample", "export-nrrd", p, "--out-prefix", tmp_path / "P")
    check(r, ["S.h5"], [p], before)
    assert not (tmp_path / "P_labels.nrrd").exists()


def test_an_echoed_cell_is_cut_to_80_characters(tmp_path):
    # Issue 12: a 100 MB header cell was echoed whole.
    args, files = c_csv(tmp_path, HEAD.strip() + "," + "y" * 200_000 + "\n0,1,2,3,4,5,6,7\n")
    r = run("recording", "import", *args, "--out", tmp_path / "R.h5")
    check(r, ["R.csv", "column 8", "y" * 77 + "..."], files, digest(files), tmp_path / "R.h5")
    assert len(r.stderr) < 400, len(r.stderr)


def limited(limit_bytes, *args):
    import resource

    def cap():
        resource.setrlimit(resource.RLIMIT_AS, (limit_bytes, limit_bytes))
    return subprocess.run([BURRBENCH, *map(str, args)], capture_output=True, text=True, timeout=120, preexec_fn=cap)


@pytest.mark.parametrize("where", ["header", "row"])
def test_csv_memory_is_bounded_by_the_file(tmp_path, where):
    # Issue 12: a 100 MB line of commas peaked at 4.2 GB (42 bytes per byte), then
    # std::bad_alloc naming no file. 50 MB of commas now fit in 800 MB of address space
    # (the program and its libraries take ~100 MB of it): exit 2 naming the line.
    commas = "," * 50_000_000
    text = (HEAD.strip() + commas + "\n0,1,2,3,4,5,6\n") if where == "header" else (HEAD + "0,1,2,3,4,5,6\n" + commas + "\n")
    p = tmp_path / "R.csv"
    p.write_text(text)
    r = limited(800 << 20, "recording", "import", "--csv", p, "--out", tmp_path / "R.h5")
    check(r, ["R.csv", "line 1 (header)" if where == "header" else "line 3", "columns"], [p], digest([p]),
          tmp_path / "R.h5")


def test_out_of_memory_is_exit_3_naming_the_file(tmp_path):
    # A file too large for the memory at hand: one line naming it, exit 3 (not "std::bad_alloc").
    p = tmp_path / "R.csv"
    p.write_text(HEAD + "".join(f"{i * 0.001:.3f},1,2,3,4,5,6\n" for i in range(3_000_000)))
    r = limited(300 << 20, "recording", "import", "--csv", p, "--out", tmp_path / "R.h5")
    assert r.returncode == 3, (r.returncode, r.stderr)
    assert r.stderr == f"burrbench: {p}: out of memory while reading it (a memory limit, or an input too large for this machine)\n"
    assert not (tmp_path / "R.h5").exists()
