"""DESIGN's rule for watch/: it may use rig, model, analysis and data_schema (the one
piece beside apps/ that joins a journal and a replay); nothing but apps/ uses it."""
from layering import foreign_includes, linked_libraries

ALLOWED = {"watch", "rig", "model", "analysis", "data_schema"}


def test_watch_includes_only_what_it_may_use():
    assert foreign_includes("watch", ALLOWED) == []


def test_watch_links_only_what_it_may_use():
    assert linked_libraries("watch") <= ALLOWED - {"watch"}


def test_no_library_below_uses_watch():
    for folder in ("data_schema", "model", "rig", "calibration", "analysis", "study", "python"):
        assert not [l for l in foreign_includes(folder, set()) if "burrbench/watch/" in l], folder
        assert "watch" not in linked_libraries(folder), folder
