"""`cmake --install` puts the Python module where Debian's /usr/bin/python3 finds it
(python/CMakeLists.txt, docs/python.md): <prefix>/lib/python3.X/dist-packages/burrbench,
which for the default prefix /usr/local is on that interpreter's own search path."""
import os
import subprocess
import sys
from pathlib import Path

BUILD = Path(os.environ["BURRBENCH_BUILD_DIR"])
SRC = Path(os.environ["BURRBENCH_SOURCE_DIR"])
PY = "/usr/bin/python3"


def test_the_installed_module_imports_and_reads_without_the_build_tree(tmp_path):
    prefix = tmp_path / "prefix"
    p = subprocess.run(["cmake", "--install", BUILD, "--prefix", prefix], capture_output=True, text=True,
                       timeout=300)
    assert p.returncode == 0, p.stderr
    ver = subprocess.run([PY, "-c", "import sys; print(f'{sys.version_info[0]}.{sys.version_info[1]}')"],
                         capture_output=True, text=True, check=True).stdout.strip()
    site = prefix / "lib" / f"python{ver}" / "dist-packages"
    assert (site / "burrbench" / "__init__.py").is_file()
    # Only the installed copy on the path: no build tree, no source tree.
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(site)
    code = ("import burrbench, sys; "
            "p = burrbench.read_params(sys.argv[1]); "
            "print(burrbench.__file__); print(sorted(p['classes']))")
    params = SRC / "examples" / "experiments" / "synthetic" / "params_true.toml"
    r = subprocess.run([PY, "-c", code, params], capture_output=True, text=True, env=env, cwd=tmp_path,
                       timeout=120)
    assert r.returncode == 0, r.stderr
    where, classes = r.stdout.splitlines()
    assert Path(where).resolve().is_relative_to(site.resolve())
    assert classes == "['compact', 'trabecular']"
    # With the default prefix no PYTHONPATH is needed: Debian's python3 searches
    # /usr/local/lib/python3.X/dist-packages itself.
    path = subprocess.run([PY, "-c", "import sys; print('\\n'.join(sys.path))"], capture_output=True,
                          text=True, env=env, check=True).stdout.splitlines()
    assert f"/usr/local/lib/python{ver}/dist-packages" in path
