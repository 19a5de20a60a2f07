"""Shared by every pytest file under tests/: the bad-input suite's tally (bad_input.py)."""
import bad_input


def pytest_terminal_summary(terminalreporter):
    cases, ok, bad = bad_input.tally()
    if cases:
        terminalreporter.write_line(
            f"bad-input suite: {cases} cases, {ok} gave exit 2 with one line naming the file")
        for line in bad:
            terminalreporter.write_line(f"  not so: {line}")
