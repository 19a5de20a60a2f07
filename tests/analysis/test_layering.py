"""analysis/ only reads files: it links data_schema alone among our libraries and
includes no header of model/, calibration/ or rig/ (DESIGN.md "Folders"; issue 14). The
replay that fills an analysis input lives in apps/ (analysis_replay)."""
import os
import re
from pathlib import Path

SRC = Path(os.environ["BURRBENCH_SOURCE_DIR"])


def test_analysis_includes_only_its_own_and_data_schema_headers():
    offenders = []
    for f in sorted((SRC / "analysis").rglob("*.[ch]pp")):
        for n, line in enumerate(f.read_text().splitlines(), 1):
            m = re.match(r'\s*#include\s+"burrbench/([a-z_]+)/', line)
            if m and m.group(1) not in ("analysis", "data_schema"):
                offenders.append(f"{f.relative_to(SRC)}:{n}: {line.strip()}")
    assert not offenders, offenders


def test_analysis_links_data_schema_alone():
    cmake = (SRC / "analysis" / "CMakeLists.txt").read_text()
    ours = set(re.findall(r"burrbench::([a-z_]+)", cmake))
    assert ours == {"data_schema"}, ours
