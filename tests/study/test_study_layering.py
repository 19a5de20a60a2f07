"""study/ uses data_schema alone among our libraries (DESIGN.md "Folders"): it reads fits
and manifests, and runs the verbs only as processes (through Snakemake)."""
import os
import re
from pathlib import Path

SRC = Path(os.environ["BURRBENCH_SOURCE_DIR"])


def test_study_includes_and_links_only_data_schema():
    offenders = []
    for f in sorted((SRC / "study").rglob("*.[ch]pp")):
        for n, line in enumerate(f.read_text().splitlines(), 1):
            m = re.match(r'\s*#include\s+"burrbench/([a-z_]+)/', line)
            if m and m.group(1) not in ("study", "data_schema"):
                offenders.append(f"{f.relative_to(SRC)}:{n}: {line.strip()}")
    assert not offenders, offenders
    assert set(re.findall(r"burrbench::([a-z_]+)", (SRC / "study" / "CMakeLists.txt").read_text())) == {"data_schema"}


def test_the_workflow_calls_burrbench_verbs_only():
    snakefile = (SRC / "study" / "Snakefile").read_text()
    shells = re.findall(r'shell:\s*\n\s*"(.*?)"\s*(?:\n\s*"(.*?)")?\n', snakefile)
    assert len(shells) == 3
    for parts in shells:
        assert parts[0].startswith("'{BB}' "), parts
