"""Each managed output says which command made it (issue 38 items 1 and 2).

A report folder's marker names its command (``analyze`` or ``stability``) and its inputs: a
command replaces only its own kind of report and refuses another's with one line; replacing a
report made from other inputs is allowed and says what changed (docs/FORMATS.md §7).
"""

from __future__ import annotations

import json

import pytest

from data_schema.errors import InputError
from data_schema.outputs import (
    REPORT_MARKER,
    check_output_folder,
    mark_report,
    replacing_note,
    report_marker,
)


def test_marker_names_the_command_and_inputs(tmp_path):
    mark_report(tmp_path, command="stability", inputs={"PAIRS": tmp_path / "p.csv", "--metrics": ["psnr", "ssim"]})
    doc = json.loads((tmp_path / REPORT_MARKER).read_text())
    assert doc["command"] == "stability" and doc["version"] == 2
    assert doc["inputs"] == {"PAIRS": [str(tmp_path / "p.csv")], "--metrics": ["psnr", "ssim"]}
    assert report_marker(tmp_path) == doc and report_marker(tmp_path / "none") is None


@pytest.mark.parametrize(("made_by", "writer"), [("stability", "analyze"), ("analyze", "stability")])
def test_a_command_refuses_another_commands_report(tmp_path, made_by, writer):
    (tmp_path / "r").mkdir()
    mark_report(tmp_path / "r", command=made_by)
    (tmp_path / "r" / "stability.csv").write_text("x\n")
    with pytest.raises(InputError, match=f"a report folder of {made_by}'s; choose another folder") as err:
        check_output_folder(tmp_path / "r", kind="report", option="--out", command=writer)
    assert "\n" not in str(err.value)
    assert check_output_folder(tmp_path / "r", kind="report", command=made_by) == tmp_path / "r"


def test_a_marker_without_a_command_stays_replaceable(tmp_path):
    (tmp_path / "r").mkdir()
    (tmp_path / "r" / REPORT_MARKER).write_text('{"format": "nvrq-report", "version": 1}\n')  # before issue 38
    for command in ("analyze", "stability"):
        assert check_output_folder(tmp_path / "r", kind="report", command=command) == tmp_path / "r"


def test_replacing_note_names_what_changed(tmp_path):
    out = tmp_path / "report"
    out.mkdir()
    first = {"RATINGS": tmp_path / "ratings.csv", "--timing": [tmp_path / "metrics.timing.csv"],
             "--metrics-table": [tmp_path / "metrics_torch.csv"], "--stability": None}
    mark_report(out, command="analyze", inputs=first)
    assert replacing_note(out, command="analyze", inputs=first) is None  # the same inputs: no note
    # the README's old sequence: the stability run dropped --timing and --metrics-table
    second = {"RATINGS": tmp_path / "ratings.csv", "--stability": tmp_path / "stability"}
    note = replacing_note(out, command="analyze", inputs=second)
    assert note.startswith(f"note: replacing the report {out} made by analyze from other inputs: ")
    assert "--metrics-table dropped (was " in note and "--timing dropped" in note and "--stability added" in note
    assert replacing_note(tmp_path / "absent", command="analyze", inputs=second) is None
