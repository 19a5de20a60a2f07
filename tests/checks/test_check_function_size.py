"""scripts/check-function-size, the function-length check of `make test`, on a unit of its
own: a function of 151 lines fails it, one of 150 passes, a NOLINT'd hot kernel passes, and a
unit that does not parse is named rather than passed over."""
import json
import os
import subprocess
from pathlib import Path

SRC = Path(os.environ["BURRBENCH_SOURCE_DIR"])
CHECK = SRC / "scripts" / "check-function-size"


def function(name, body_lines):
    """A function whose body spans `body_lines` lines as clang-tidy counts them ('{' to '}')."""
    return f"int {name}(int x) {{\n" + "  x += 1;\n" * (body_lines - 2) + "  return x;\n}\n"


def run_check(tmp_path, text):
    (tmp_path / "src" / "model").mkdir(parents=True)
    (tmp_path / "src" / "model" / "unit.cpp").write_text(text)
    (tmp_path / "compile_commands.json").write_text(json.dumps(
        [{"directory": str(tmp_path), "file": "src/model/unit.cpp",
          "command": "c++ -std=c++20 -c src/model/unit.cpp"}]))
    return subprocess.run([str(CHECK), str(tmp_path), "--source-dir", str(tmp_path / "src"),
                           "--folders", "model"], capture_output=True, text=True, timeout=300)


def test_only_the_function_over_150_lines_fails(tmp_path):
    text = (function("at_limit", 150) + function("over_limit", 151)
            + "// NOLINTNEXTLINE(readability-function-size) hot kernel: one pass over the voxels\n"
            + function("kernel", 400))
    p = run_check(tmp_path, text)
    assert p.returncode == 1, p.stdout + p.stderr
    named = [line for line in p.stdout.splitlines() if "lines (limit 150)" in line]
    assert len(named) == 1 and "'over_limit' is 151 lines" in named[0], p.stdout


def test_a_tree_within_the_limit_passes(tmp_path):
    p = run_check(tmp_path, function("at_limit", 150) + function("brief", 3))
    assert p.returncode == 0, p.stdout + p.stderr
    assert "0 function(s) over 150 lines" in p.stdout


def test_a_unit_that_does_not_parse_is_named(tmp_path):
    p = run_check(tmp_path, "int broken( {\n")
    assert p.returncode == 2
    assert "model/unit.cpp: clang-tidy failed" in p.stderr
