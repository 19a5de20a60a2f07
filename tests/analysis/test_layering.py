"""analysis/ only reads files: it links data_schema alone among our libraries and
includes no header of model/, calibration/ or rig/ (DESIGN.md "Folders"; issue 14). The
prediction and context a report is made from are built in apps/ (report_prediction)."""
from layering import foreign_includes, linked_libraries


def test_analysis_includes_only_its_own_and_data_schema_headers():
    assert not foreign_includes("analysis", ("analysis", "data_schema"))


def test_analysis_links_data_schema_alone():
    assert linked_libraries("analysis") == {"data_schema"}
