"""study/ uses data_schema alone among our libraries (DESIGN.md "Folders"): it reads fits
and manifests, and runs the verbs only as processes (through Snakemake)."""
import re

from layering import SRC, foreign_includes, linked_libraries


def test_study_includes_and_links_only_data_schema():
    assert not foreign_includes("study", ("study", "data_schema"))
    assert linked_libraries("study") == {"data_schema"}


def test_the_workflow_calls_burrbench_verbs_only():
    snakefile = (SRC / "study" / "Snakefile").read_text()
    shells = re.findall(r'shell:\s*\n\s*"(.*?)"\s*(?:\n\s*"(.*?)")?\n', snakefile)
    assert len(shells) == 5  # import_sample, import_recording, calibrate, validate, summarize
    for parts in shells:
        assert parts[0].startswith("'{BB}' "), parts
        # One verb per job: no second command chained in.
        assert not re.search(r"&&|;|\|\|(?! \[)", parts[0] + parts[1]), parts
