"""The bad-input suite's rule, in one place: a refused input is exit code 2 and one stderr
line that names the file (and holds the field and what was expected). Every refusal a test
checks through here is counted; tests/conftest.py prints the tally after a pytest run, and
bench/bad_input.sh runs every test file that uses this module and prints the total:
    bad-input suite: N cases, M gave exit 2 with one line naming the file
"""
import os

CASES = []  # (test id, case label, ok, why not)


def refused(rc, stderr, files, *fragments, label=""):
    """Records one bad-input case; True when the command exited 2 with exactly one stderr
    line naming one of `files` (a path or a list of paths; the path as given or its base
    name) and holding every fragment."""
    if isinstance(files, (str, os.PathLike)):
        files = [files]
    lines = (stderr or "").strip().splitlines()
    why = ""
    if rc != 2:
        why = f"exit {rc}"
    elif len(lines) != 1:
        why = f"{len(lines)} stderr lines"
    elif not any(str(f) in lines[0] or os.path.basename(str(f)) in lines[0] for f in files):
        why = "the file is not named"
    else:
        missing = [f for f in fragments if f not in lines[0]]
        if missing:
            why = f"no {missing[0]!r}"
    test = os.environ.get("PYTEST_CURRENT_TEST", "?").split(" ")[0]
    CASES.append((test, label, not why, why))
    return not why


def assert_refused(rc, stderr, files, *fragments, label=""):
    assert refused(rc, stderr, files, *fragments, label=label), (rc, stderr, fragments)


def tally():
    """(cases, refused as the rule asks, the others as 'test [label]: why')."""
    bad = [f"{t} {lab}".strip() + f": {why}" for t, lab, ok, why in CASES if not ok]
    return len(CASES), len(CASES) - len(bad), bad
