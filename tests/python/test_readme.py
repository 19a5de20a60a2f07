"""README's Python lines run as written after `make build` (issue 58, item 6a): taken from
README.md verbatim and run by /usr/bin/python3 with PYTHONPATH=build/python as README says,
in a fresh folder laid out like the checkout (`build` links to this build, so the lines
read what the build wrote and can write nothing into the checkout). They must print what
README says: three rows of x, y, z force and the unit N."""
import os
import re
import subprocess
from pathlib import Path

SRC = Path(os.environ["BURRBENCH_SOURCE_DIR"])
BUILD = Path(os.environ["BURRBENCH_BUILD_DIR"])


def readme_python():
    """The README's one ```python block."""
    blocks = re.findall(r"^```python\n(.*?)^```$", (SRC / "README.md").read_text(), re.S | re.M)
    assert len(blocks) == 1, blocks
    return blocks[0]


def test_the_readme_python_lines_run_as_written(tmp_path):
    code = readme_python()
    assert "PYTHONPATH=build/python" in code  # what the environment below follows
    (tmp_path / "build").symlink_to(BUILD)
    (tmp_path / "snippet.py").write_text(code)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    p = subprocess.run(["/usr/bin/python3", "snippet.py"], cwd=tmp_path, env={**env, "PYTHONPATH": "build/python"},
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    rows = re.findall(r"\[\s*(-?[\d.e+-]+)\s+(-?[\d.e+-]+)\s+(-?[\d.e+-]+)\s*\]", p.stdout)
    assert len(rows) == 3, p.stdout
    assert all(abs(float(v)) < 1e3 for row in rows for v in row), rows
    assert p.stdout.rstrip().endswith("N"), p.stdout
    assert sorted(x.name for x in tmp_path.iterdir()) == ["build", "snippet.py"]  # wrote nothing
