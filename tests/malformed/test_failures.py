"""Failures of the machine rather than of the input (issue 13 item 8): a full disk during
``annotate build``/``export``/``analyze``, a read-only study folder, and the real console
scripts (a few subprocess runs). Each ends with one stderr line, exit status 2, no traceback,
and nothing half-written left behind.
"""

from __future__ import annotations

import errno
import os
import sqlite3
import subprocess
import sys

import pandas as pd
import pytest
from malformed_world import copy_into, snapshot, write_scene


def _one_line(capfd) -> str:
    out, err = capfd.readouterr()
    assert "Traceback" not in out + err
    lines = err.strip("\n").split("\n")
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    return lines[0]


def _enospc(*args, **kwargs):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def test_disk_full_during_export_leaves_no_part_file(world, tmp_path, capfd, monkeypatch):
    from annotate.cli import main

    st = copy_into(world, "study", tmp_path)
    before = snapshot(tmp_path)
    real = pd.DataFrame.to_csv

    def half_then_full(self, path, *a, **kw):  # writes part of the table, then the disk is full
        real(self.iloc[:1], path, *a, **kw)
        _enospc()

    monkeypatch.setattr(pd.DataFrame, "to_csv", half_then_full)
    rc = main(["export", str(st), "--out", str(tmp_path / "ratings.csv")])
    line = _one_line(capfd)
    assert rc == 2 and "ratings.csv" in line and "No space left" in line
    after = snapshot(tmp_path)
    # the votes database may have gained SQLite companions; nothing else is new or changed
    assert after == before


def test_disk_full_during_build_leaves_nothing(world, tmp_path, capfd, monkeypatch):
    import annotate.crops
    from annotate.cli import main

    calls = {"n": 0}
    real = annotate.crops.write_image

    def fill_up(path, img, **kw):
        calls["n"] += 1
        if calls["n"] > 3:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        return real(path, img, **kw)

    monkeypatch.setattr(annotate.crops, "write_image", fill_up)
    rc = main(["build", str(tmp_path / "st"), "--pairs", str(world / "toy" / "pairs.csv"), "--scene",
               str(world / "toy" / "scene"), "--tracks", "2", "--frames-per-track", "2", "--size", "32x32"])
    out, err = capfd.readouterr()
    assert rc == 2 and "Traceback" not in err
    assert err.strip().splitlines()[-1].startswith("error: ") and "No space left" in err
    assert list(tmp_path.iterdir()) == []  # no study, no temporary folder


@pytest.mark.parametrize("command", ["export", "simulate"])
def test_read_only_study_folder(world, tmp_path, capfd, monkeypatch, command):
    from annotate.cli import main

    st = copy_into(world, "study", tmp_path)
    os.chmod(st, 0o555)
    os.chmod(st / "votes.sqlite", 0o444)
    if os.geteuid() == 0:  # root ignores file modes: SQLite's answer on a read-only folder instead
        import annotate.store

        def read_only(*a, **kw):
            raise sqlite3.OperationalError("attempt to write a readonly database")

        monkeypatch.setattr(annotate.store.sqlite3, "connect", read_only)
    try:
        argv = ["export", str(st), "--out", str(tmp_path / "r.csv")] if command == "export" \
            else ["simulate", str(st), "--raters", "1"]
        rc = main(argv)
        line = _one_line(capfd)
        assert rc == 2 and "votes.sqlite" in line
        assert not (tmp_path / "r.csv").exists()
    finally:
        os.chmod(st, 0o755)


def _script(name: str) -> str:
    path = os.path.join(os.path.dirname(sys.executable), name)
    return path if os.path.exists(path) else name


def test_console_scripts_one_line(world, tmp_path):
    """The real entry points: argparse errors, data-destroying outputs and a missing image."""
    st = copy_into(world, "study", tmp_path)
    scene = write_scene(tmp_path / "scene")
    df = pd.read_csv(world / "toy" / "pairs.csv")
    df["render_path"] = "images/nowhere.png"
    df.to_csv(tmp_path / "pairs.csv", index=False)
    runs = [
        ([_script("nvrq"), "synth", str(tmp_path / "s"), "--size", "-640x360"], "--size"),
        ([_script("nvrq"), "pairs", str(scene), "--out", str(scene / "images.csv")], "scene folder"),
        ([_script("nvrq"), "score", str(tmp_path / "pairs.csv"), "--scene", str(world / "toy" / "scene"),
          "--metrics", "psnr", "--out", str(tmp_path / "m.csv"), "--quiet"], "render_path"),
        ([_script("annotate"), "export", str(st), "--out", str(st / "items.csv")], "study folder"),
        ([_script("analyze"), str(world / "ratings.csv"), "--out", str(st)], "study"),
    ]
    before = snapshot(tmp_path)
    for argv, fragment in runs:
        proc = subprocess.run(argv, capture_output=True, text=True, timeout=120)
        lines = proc.stderr.strip("\n").split("\n")
        assert proc.returncode == 2, (argv, proc.stderr)
        assert len(lines) == 1 and lines[0].startswith("error: ") and fragment in lines[0], proc.stderr
    assert snapshot(tmp_path) == before


def test_export_counts_votes_it_cannot_place(world, tmp_path, capfd):
    """Issue 13 items 6 and 14: a vote for an unknown item, or one recorded under an old study
    id, is not silently dropped: export says how many and why (1 + 2 here, written by hand)."""
    from annotate.cli import main

    st = copy_into(world, "study", tmp_path)
    n_before = len(pd.read_csv(world / "ratings.csv"))
    with sqlite3.connect(st / "votes.sqlite") as con:
        study_id = con.execute("SELECT study FROM votes LIMIT 1").fetchone()[0]
        row = ("2026-01-01T00:00:00.000Z", 500)
        con.execute("INSERT INTO votes VALUES (?, 'ann', 'no-such-item', 1, ?, ?)", (study_id, *row))
        for item in ("a", "b"):
            con.execute("INSERT INTO votes VALUES ('old-study', 'ann', ?, 0, ?, ?)", (item, *row))
    capfd.readouterr()
    assert main(["export", str(st), "--out", str(tmp_path / "r.csv")]) == 0
    err = capfd.readouterr().err
    assert len(pd.read_csv(tmp_path / "r.csv")) == n_before
    assert "warning: 3 votes not exported: 1 for items not in items.csv; 2 recorded under another " \
           "study id" in err


def test_report_folder_replaced_whole_and_kept_on_a_full_disk(world, tmp_path, capfd, monkeypatch):
    """A report folder of ours (marker file) is replaced as a whole; a disk that fills up
    while the next report is built leaves the previous one as it was, and no temporary folder."""
    import analysis.report.report
    from analysis.cli import main
    from data_schema.outputs import REPORT_MARKER

    argv = [str(world / "ratings.csv"), "--out", str(tmp_path / "rep"), "--bootstrap", "0", "--quiet"]
    assert main(argv) == 0 and (tmp_path / "rep" / REPORT_MARKER).is_file()
    (tmp_path / "rep" / "stale.txt").write_text("from an older run")
    assert main(argv) == 0
    assert (tmp_path / "rep" / REPORT_MARKER).is_file() and not (tmp_path / "rep" / "stale.txt").exists()
    capfd.readouterr()
    before = snapshot(tmp_path)
    monkeypatch.setattr(analysis.report.report, "_build", _enospc)
    rc = main(argv)
    line = _one_line(capfd)
    assert rc == 2 and "No space left" in line
    assert snapshot(tmp_path) == before and sorted(p.name for p in tmp_path.iterdir()) == ["rep"]


def test_valid_world_passes(world, tmp_path, capfd):
    """The corpus's unbroken inputs are accepted by the same commands (so each case's error
    comes from what it breaks): pairs, score, build with --metrics-table, export."""
    from annotate.cli import main as annotate
    from nvrq.cli import main as nvrq

    assert nvrq(["pairs", str(world / "scene"), "--out", str(tmp_path / "p.csv"), "--quiet"]) == 0
    assert nvrq(["score", str(world / "toy" / "pairs.csv"), "--scene", str(world / "toy" / "scene"),
                 "--metrics", "psnr", "--out", str(tmp_path / "m.csv"), "--quiet"]) == 0
    assert annotate(["build", str(tmp_path / "st"), "--pairs", str(world / "toy" / "pairs.csv"), "--scene",
                     str(world / "toy" / "scene"), "--tracks", "1", "--frames-per-track", "1", "--size",
                     "32x32", "--metrics-table", str(world / "metrics.csv")]) == 0
    assert annotate(["export", str(tmp_path / "st"), "--out", str(tmp_path / "r.csv")]) == 0
    err = capfd.readouterr().err
    assert "error" not in err and "Traceback" not in err
    assert len(pd.read_csv(tmp_path / "m.csv")) == len(pd.read_csv(world / "toy" / "pairs.csv"))
    assert "psnr" in pd.read_csv(tmp_path / "st" / "metrics.csv").columns
