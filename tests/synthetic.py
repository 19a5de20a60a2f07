"""The shipped synthetic experiment (examples/experiments/synthetic/make.sh) in a fresh
folder, and the CLI runner the tests that use it share."""
import os
import subprocess
from pathlib import Path
from report_context import context

BURRBENCH = os.environ["BURRBENCH"]
SRC = Path(os.environ["BURRBENCH_SOURCE_DIR"])


def make_synthetic(folder):
    """Writes the synthetic experiment into `folder` (created) and returns it."""
    subprocess.run(["sh", str(SRC / "examples/experiments/synthetic/make.sh"), BURRBENCH, str(folder)],
                   check=True, capture_output=True, timeout=300)
    return Path(folder)


def write_variant(base, name, *changes):
    """`base`/`name`.toml: the experiment.toml in folder `base` with each (old, new) of
    `changes` replaced in turn, every old text of which must be there; returns its path."""
    text = (Path(base) / "experiment.toml").read_text()
    for old, new in changes:
        assert old in text, old
        text = text.replace(old, new)
    path = Path(base) / f"{name}.toml"
    path.write_text(text)
    return path


def run_ok(*args, timeout=900):
    """`burrbench ARGS`, which must succeed; its stdout."""
    p = subprocess.run([BURRBENCH, *map(str, args)], capture_output=True, text=True, timeout=timeout)
    assert p.returncode == 0, p.stdout + p.stderr
    return p.stdout


def quick_fit(manifest, out, *extra):
    """A single-start `burrbench calibrate` of `manifest` into `out`, without profiles,
    cross-validation or the discretization check (the CLI tests of the checks after a fit),
    with further options `extra`: (its stdout, fit.json)."""
    import json
    stdout = run_ok("calibrate", manifest, "--out", out, "--starts", 1, "--no-profiles", "--no-cross-validation",
                    "--no-discretization-check", *extra)
    return stdout, json.loads((Path(out) / "fit.json").read_text())


def fit_warnings(manifest, out, prefix, *extra):
    """quick_fit's fit.json and its warnings that begin with `prefix`, which the summary must
    print as they are: (fit.json, those warnings)."""
    stdout, fit = quick_fit(manifest, out, *extra)
    said = [w for w in fit["settings"]["warnings"] if w.startswith(prefix)]
    assert ["warning: " + w for w in said] == [line for line in stdout.splitlines() if prefix in line]
    return fit, said


# How make.sh synthesises each recording: its seed and its lag (ms).
MADE = {"plunge": (11, 0.0), "sweep": (12, 2.0), "polish": (13, 2.0)}


def resynth(exp, recording, *extra, lag_ms=None):
    """Makes `recording` of the synthetic experiment in folder `exp` again as make.sh does
    (its seed and lag, σ 0.02 N, the bias), with another lag (ms) or further `synth`
    options (`extra`), in place of the one there."""
    exp = Path(exp)
    seed, made_lag = MADE[recording]
    (exp / f"{recording}.h5").unlink()
    (exp / f"{recording}.truth.json").unlink()
    run_ok("synth", "--sample", exp / "sample.h5", "--protocol", SRC / "examples" / "protocols" / f"{recording}.toml",
           "--params", exp / "params_true.toml", "--out", exp / f"{recording}.h5", "--truth",
           exp / f"{recording}.truth.json", "--noise-N", "0.02", "--bias-N", "0.05,-0.03,0.1", "--lag-ms",
           made_lag if lag_ms is None else lag_ms, "--seed", seed, *extra)


def validate_warnings(manifest, out, marker):
    """`burrbench validate` of `manifest` with its folder's true constants, the example
    release criteria and no verification, into `out`: (exit code 0 or 1, the stderr warnings
    holding `marker`, without "warning: "). They must be the analysis's limitations that
    hold it."""
    import json
    p = subprocess.run([BURRBENCH, "validate", manifest, "--params", Path(manifest).parent / "params_true.toml",
                        "--criteria", SRC / "examples" / "criteria" / "release.toml", "--out", out,
                        "--no-verification"], capture_output=True, text=True, timeout=600)
    assert p.returncode in (0, 1), p.stderr
    said = [line[len("warning: "):] for line in p.stderr.splitlines() if line.startswith("warning: ") and marker in line]
    limits = context(out)["findings"]
    assert [w for w in limits if marker in w] == said, (limits, said)
    return p.returncode, said


def drill_plunge_twice(exp, folder):
    """A copy of the synthetic experiment `exp` in `folder` whose plunge was drilled twice:
    plunge.h5 copied to plunge_again.h5 and listed as a recording of its own (a second
    drilling of the same spot), and plunge.h5 listed once more as plunge_listed_again with
    role "validate" (one drilling, once per role: not a pair). Returns the new manifest."""
    import shutil
    folder = Path(folder)
    shutil.copytree(exp, folder)
    shutil.copy(folder / "plunge.h5", folder / "plunge_again.h5")
    manifest = folder / "experiment.toml"
    m = manifest.read_text()
    first = m.index("[[recordings]]")
    block = m[first:m.index("[[recordings]]", first + 1)]
    m += "\n" + block.replace('id = "plunge"', 'id = "plunge_again"').replace('"plunge.h5"', '"plunge_again.h5"')
    assert 'role = "calibrate"' in block
    m += "\n" + block.replace('id = "plunge"', 'id = "plunge_listed_again"').replace('role = "calibrate"',
                                                                                    'role = "validate"')
    manifest.write_text(m)
    return manifest


# The one warning drill_plunge_twice's experiment gives, as it begins.
PLUNGE_TWICE_WARNING = "Recordings plunge and plunge_again removed the same bone of sample S1: "


def cut_stream(recording, stream, from_s, to_s):
    """Removes, in place, the samples of `stream` (stage: positions; ft_sensor: forces) of
    the recording file `recording` strictly between from_s and to_s (seconds from its first
    force sample), as a device that stopped answering would leave them. Returns (t_a, t_b):
    that stream's samples around the gap, in seconds on the same clock (None where the cut
    reaches the stream's end)."""
    import h5py
    with h5py.File(recording, "r+") as f:
        t0 = f["streams/ft_sensor/t_ns"][0]
        group = f["streams/" + stream]
        t = (group["t_ns"][()] - t0) * 1e-9
        keep = ~((t > from_s) & (t < to_s))

        def cut(g):
            for name in list(g):
                item = g[name]
                if isinstance(item, h5py.Group):
                    cut(item)
                elif item.shape and item.shape[0] == len(t):
                    data, attrs = item[()][keep], dict(item.attrs)
                    del g[name]
                    g.create_dataset(name, data=data).attrs.update(attrs)
        cut(group)
    kept = t[keep]
    before, after = kept[kept <= from_s], kept[kept >= to_s]
    return before.max() if before.size else None, after.min() if after.size else None


def drop_samples(exp, folder, recording="sweep", from_s=1.0, to_s=1.3, stream="stage"):
    """A copy of the synthetic experiment `exp` in `folder` whose `recording` lost the samples
    of `stream` between from_s and to_s (cut_stream). Returns (manifest, t_a, t_b)."""
    import shutil
    folder = Path(folder)
    shutil.copytree(exp, folder)
    t_a, t_b = cut_stream(folder / f"{recording}.h5", stream, from_s, to_s)
    return folder / "experiment.toml", t_a, t_b


# The warning drop_samples's experiment gives, as it begins (stage samples dropped).
STAGE_GAP_WARNING = "Recording sweep: the stage measured no position for "


START_IN_BONE_WARNING = "Recording plunge: the burr is already "


def start_late(exp, folder, from_s, streams=("stage", "spindle", "ft_sensor")):
    """A copy of the synthetic experiment `exp` in `folder` whose plunge's `streams` begin at
    from_s (cut_stream). Its burr centre starts 0.5 mm above the burr's touch of the flat
    bone top (z = 3 mm) and feeds down at 0.5 mm/s, 0.25 mm deep at most: at from_s it is
    0.5·from_s − 0.5 mm deep. Returns the copy's manifest."""
    import shutil
    shutil.copytree(exp, folder)
    for stream in streams:  # the force stream last: it sets the clock cut_stream reads
        cut_stream(folder / "plunge.h5", stream, -1.0, from_s)
    return folder / "experiment.toml"
