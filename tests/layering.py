"""DESIGN.md's folder rule, checked from the sources: which of our headers a folder
includes and which of our libraries its CMakeLists links."""
import os
import re
from pathlib import Path

SRC = Path(os.environ["BURRBENCH_SOURCE_DIR"])


def foreign_includes(folder, allowed):
    """Lines of folder/**.[ch]pp including a burrbench/<x>/ header with x not in allowed."""
    out = []
    for f in sorted((SRC / folder).rglob("*.[ch]pp")):
        for n, line in enumerate(f.read_text().splitlines(), 1):
            m = re.match(r'\s*#include\s+"burrbench/([a-z_]+)/', line)
            if m and m.group(1) not in allowed:
                out.append(f"{f.relative_to(SRC)}:{n}: {line.strip()}")
    return out


def linked_libraries(folder):
    """Our libraries (burrbench::x) the folder's CMakeLists names."""
    return set(re.findall(r"burrbench::([a-z_]+)", (SRC / folder / "CMakeLists.txt").read_text()))
