"""calibration/'s public face (docs/architecture.md "Public faces"): include/ holds only the
headers other folders use; the solver machinery's headers sit in internal/, which only the
library itself and its own tests (through burrbench::calibration_internal) can reach."""
import re

from layering import SRC

CAL = SRC / "calibration"
PUBLIC = CAL / "include" / "burrbench" / "calibration"
INTERNAL = CAL / "internal" / "burrbench" / "calibration"
INCLUDE = re.compile(r'\s*#include\s+"burrbench/calibration/([a-z_]+\.hpp)"')


def includes(path):
    return [m.group(1) for line in path.read_text().splitlines() if (m := INCLUDE.match(line))]


def test_public_headers_include_no_internal_one():
    # A public header that drags in an internal one compiles inside calibration/ and fails
    # in apps/ and python/, which see include/ alone.
    internal = {h.name for h in INTERNAL.glob("*.hpp")}
    dragged = [f"{h.name} includes {i}" for h in sorted(PUBLIC.glob("*.hpp")) for i in includes(h) if i in internal]
    assert not dragged


def test_every_public_header_is_used_outside_calibration():
    # A header no other folder uses belongs in internal/ (tests do not count: they reach it).
    used = set()
    for folder in ("apps", "python", "analysis", "study", "bench", "rig", "model", "data_schema"):
        for f in (SRC / folder).rglob("*.[ch]pp"):
            used.update(includes(f))
    # A public header is used when another folder includes it or a used public header does.
    for _ in range(3):
        used.update(i for h in PUBLIC.glob("*.hpp") if h.name in used for i in includes(h))
    unused = sorted(h.name for h in PUBLIC.glob("*.hpp") if h.name not in used)
    assert not unused


def test_only_calibration_tests_link_the_internal_target():
    lists = [SRC / "CMakeLists.txt", *SRC.glob("*/CMakeLists.txt"), *SRC.glob("*/*/CMakeLists.txt")]
    users = sorted(str(f.relative_to(SRC)) for f in lists
                   if f.relative_to(SRC).parts[0] != "build" and "calibration_internal" in f.read_text())
    assert users == ["calibration/CMakeLists.txt", "tests/CMakeLists.txt"]
