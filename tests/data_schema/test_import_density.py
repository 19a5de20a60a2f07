"""Density calibration from a phantom: a synthetic CT (NRRD written by fixtures_volumes.py)
holds four HA rods of known density and a block of known density, with grey = (ρ − b)/a
plus Gaussian noise. `sample export-ct --density` must recover a and b to 1 %, the block's
mg HA/cm³ to 1 %, and `sample import --density` χ = ρ/ρ_tissue of the block to 1 %; the
segmentation records its thresholds in grey values and mg HA/cm³, and the tissue density
with its reference."""
import json
import os
import subprocess

import h5py
import numpy as np
import pytest

from bad_input import assert_refused
from fixtures_volumes import read_nrrd, write_nrrd

BURRBENCH = os.environ["BURRBENCH"]
SLOPE, INTERCEPT = 0.45, -180.0           # mg HA/cm³ per grey, mg HA/cm³ at grey 0 (the truth)
RODS = [(0.0, (1.2, 1.2)), (250.0, (3.6, 1.2)), (500.0, (1.2, 3.6)), (1000.0, (3.6, 3.6))]  # density, centre x,y (mm)
BLOCK = 600.0                              # mg HA/cm³: χ = 0.5 at the default 1200 tissue density
VOXEL = 0.1


def run(*args):
    return subprocess.run([BURRBENCH, *map(str, args)], capture_output=True, text=True, timeout=300)


def grey(rho):
    return (rho - INTERCEPT) / SLOPE


def phantom_ct(path, seed=5, noise=40.0):
    """60×60×30 voxels of 0.1 mm: air (−1000 mg/cm³ equivalent grey, i.e. below any rod),
    four rods of radius 0.8 mm along z in the y < 4.8 mm half, a block in the other half."""
    rng = np.random.default_rng(seed)
    nz, ny, nx = 30, 60, 60
    z, y, x = np.mgrid[0:nz, 0:ny, 0:nx] * VOXEL
    rho = np.full((nz, ny, nx), -300.0)
    for d, (cx, cy) in RODS:
        rho[(x - cx) ** 2 + (y - cy) ** 2 <= 0.8 ** 2] = d
    block = (x >= 1.0) & (x <= 4.9) & (y >= 5.0) & (y <= 5.8)
    rho[block] = BLOCK
    g = grey(rho) + rng.normal(0, noise, rho.shape)
    write_nrrd(path, g.astype(np.float32), spacing=(VOXEL,) * 3)
    return block


def rods_toml(path, rods=RODS, extra=""):
    lines = ['format = "burrbench.density"', 'format_version = "1.0"', extra]
    for d, (cx, cy) in rods:
        lines += ["[[rod]]", f"density_mg_cm3 = {d}", f"center_mm = [{cx}, {cy}, 1.5]", "radius_mm = 0.6",
                  "length_mm = 2.0"]
    path.write_text("\n".join(lines) + "\n")


def test_rods_recover_slope_intercept_and_block_density(tmp_path):
    block = phantom_ct(tmp_path / "ct.nrrd")
    rods_toml(tmp_path / "phantom.toml")
    out = tmp_path / "rho.nrrd"
    r = run("sample", "export-ct", "--ct", tmp_path / "ct.nrrd", "--density", tmp_path / "phantom.toml", "--out", out)
    assert r.returncode == 0, r.stderr
    rho, fields = read_nrrd(out)
    kv = dict(line.split(":=", 1) for line in open(out, "rb").read().split(b"\n\n", 1)[0].decode().splitlines()
              if ":=" in line)
    cal = json.loads(kv["burrbench_source"])["density_calibration"]
    slope_err = abs(cal["slope_mg_cm3_per_grey"] / SLOPE - 1)
    intercept_err = abs(cal["intercept_mg_cm3"] / INTERCEPT - 1)
    print(f"slope {cal['slope_mg_cm3_per_grey']:.5f} (error {100 * slope_err:.3f} %), "
          f"intercept {cal['intercept_mg_cm3']:.3f} (error {100 * intercept_err:.3f} %), R² {cal['r_squared']:.6f}")
    assert slope_err < 0.01 and intercept_err < 0.01
    assert len(cal["rods"]) == 4 and all(rod["voxels"] > 100 for rod in cal["rods"])
    assert cal["tissue_density_mg_cm3"] == 1200 and "Tassani" in cal["tissue_density_reference"]
    block_mean = rho[block].mean()
    print(f"block {block_mean:.2f} mg HA/cm3 (truth {BLOCK})")
    assert abs(block_mean / BLOCK - 1) < 0.01
    sources = json.loads(kv["burrbench_inputs"])
    assert {os.path.basename(s["path"]) for s in sources} == {"ct.nrrd", "phantom.toml"}


def test_import_maps_density_to_chi_and_records_it(tmp_path):
    block = phantom_ct(tmp_path / "ct.nrrd")
    rods_toml(tmp_path / "phantom.toml")
    out = tmp_path / "S.h5"
    r = run("sample", "import", "--ct", tmp_path / "ct.nrrd", "--density", tmp_path / "phantom.toml",
            "--threshold-mg-cm3", "300", "--out", out)
    assert r.returncode == 0, r.stderr
    with h5py.File(out, "r") as f:
        chi = f["fraction"][()]
        seg = json.loads(f["segmentation_json"][()])
        paths = [p.decode() if isinstance(p, bytes) else p for p in f["sources/path"][()]]
    cal = seg["density_calibration"]
    assert seg["threshold_mg_HA_cm3"] == pytest.approx(300, rel=1e-9)
    assert seg["threshold"] == pytest.approx((300 - cal["intercept_mg_cm3"]) / cal["slope_mg_cm3_per_grey"])
    assert seg["empty_mg_HA_cm3"] == pytest.approx(0, abs=1e-6) and seg["bone_mg_HA_cm3"] == pytest.approx(1200)
    assert seg["empty_grey_source"] == "density calibration"
    # χ of the block (its interior, away from the partial-volume edge): ρ/1200 = 0.5.
    interior = block.copy()
    interior[:, :, :] &= np.roll(block, 1, 1) & np.roll(block, -1, 1) & np.roll(block, 1, 2) & np.roll(block, -1, 2)
    chi_mean = chi[interior].mean()
    print(f"block chi {chi_mean:.4f} (truth {BLOCK / 1200})")
    assert abs(chi_mean / (BLOCK / 1200) - 1) < 0.01
    assert any(p.endswith("phantom.toml") for p in paths)


def test_given_slope_and_intercept_with_another_tissue_density(tmp_path):
    block = phantom_ct(tmp_path / "ct.nrrd")
    (tmp_path / "qc.toml").write_text(
        'format = "burrbench.density"\nformat_version = "1.0"\n'
        f"slope_mg_cm3_per_grey = {SLOPE}\nintercept_mg_cm3 = {INTERCEPT}\ntissue_density_mg_cm3 = 1000\n")
    r = run("sample", "import", "--ct", tmp_path / "ct.nrrd", "--density", tmp_path / "qc.toml", "--threshold-mg-cm3",
            "300", "--out", tmp_path / "S.h5")
    assert r.returncode == 0, r.stderr
    with h5py.File(tmp_path / "S.h5", "r") as f:
        chi = f["fraction"][()]
        seg = json.loads(f["segmentation_json"][()])
    assert seg["density_calibration"]["source"] == "given slope and intercept"
    assert seg["density_calibration"]["tissue_density_source"] == "given"
    assert abs(chi[block].mean() / 0.6 - 1) < 0.01   # 600 / 1000


@pytest.mark.parametrize("case,toml,fragments", [
    ("rods and slope", "slope_mg_cm3_per_grey = 1\nintercept_mg_cm3 = 0\n" + "[[rod]]\ndensity_mg_cm3 = 0\n"
     "center_mm = [1.2, 1.2, 1.5]\nradius_mm = 0.6\n[[rod]]\ndensity_mg_cm3 = 500\ncenter_mm = [1.2, 3.6, 1.5]\n"
     "radius_mm = 0.6\n", ["rod", "not both"]),
    ("one density", "[[rod]]\ndensity_mg_cm3 = 100\ncenter_mm = [1.2, 1.2, 1.5]\nradius_mm = 0.6\n"
     "[[rod]]\ndensity_mg_cm3 = 100\ncenter_mm = [3.6, 1.2, 1.5]\nradius_mm = 0.6\n", ["two different densities"]),
    ("rod outside", "[[rod]]\ndensity_mg_cm3 = 0\ncenter_mm = [1.2, 1.2, 1.5]\nradius_mm = 0.6\n"
     "[[rod]]\ndensity_mg_cm3 = 500\ncenter_mm = [40, 40, 1.5]\nradius_mm = 0.6\n", ["rod[1]", "at least 8 voxel"]),
    ("negative slope", "slope_mg_cm3_per_grey = -1\nintercept_mg_cm3 = 0\n", ["slope_mg_cm3_per_grey", "positive"]),
    ("no intercept", "slope_mg_cm3_per_grey = 1\n", ["intercept_mg_cm3"]),
    ("unknown key", "slope_mg_cm3_per_grey = 1\nintercept_mg_cm3 = 0\ncolour = 1\n", ["colour"]),
    ("rods swapped", "[[rod]]\ndensity_mg_cm3 = 1000\ncenter_mm = [1.2, 1.2, 1.5]\nradius_mm = 0.6\n"
     "[[rod]]\ndensity_mg_cm3 = 0\ncenter_mm = [3.6, 3.6, 1.5]\nradius_mm = 0.6\n", ["rise with density"]),
])
def test_bad_phantom_files(tmp_path, case, toml, fragments):
    phantom_ct(tmp_path / "ct.nrrd")
    p = tmp_path / "p.toml"
    p.write_text('format = "burrbench.density"\nformat_version = "1.0"\n' + toml)
    r = run("sample", "import", "--ct", tmp_path / "ct.nrrd", "--density", p, "--out", tmp_path / "S.h5")
    assert_refused(r.returncode, r.stderr, p, *fragments, label=case)
    assert not (tmp_path / "S.h5").exists()


def test_density_options_that_do_not_go_together(tmp_path):
    phantom_ct(tmp_path / "ct.nrrd")
    rods_toml(tmp_path / "p.toml")
    base = ["sample", "import", "--ct", tmp_path / "ct.nrrd", "--out", tmp_path / "S.h5"]
    for extra, frag in ((["--threshold-mg-cm3", "300"], "--density"),
                        (["--density", tmp_path / "p.toml", "--bone-grey", "3000"], "--bone-grey"),
                        (["--density", tmp_path / "p.toml", "--threshold", "10", "--threshold-mg-cm3", "3"], "not both")):
        r = run(*base, *extra)
        assert_refused(r.returncode, r.stderr, "<command line>", frag, label=frag)
