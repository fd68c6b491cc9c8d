"""What the three CLIs say about themselves (issue 29 item 10): ``--version``, help text and a
default on every ``annotate`` option, one spelling of each positional, a comma list shown as
one value, and progress bars only on a terminal.

(That ``--help`` imports no heavy package is tests/test_import_layers.py; its time is
benchmarks/bench_cli_help.py.)
"""

from __future__ import annotations

import argparse
import fcntl
import os
import pty
import struct
import subprocess
import sys
import termios
from pathlib import Path

import pytest

import nvrq
from analysis.cli import build_parser as analyze_parser
from analysis.cli import main as analyze_main
from annotate.cli import build_parser as annotate_parser
from annotate.cli import main as annotate_main
from nvrq.cli import main as nvrq_main
from nvrq.cli_types import show_progress

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("prog, main", [("nvrq", nvrq_main), ("annotate", annotate_main),
                                        ("analyze", analyze_main)])
def test_version_on_every_command(prog, main, capsys):
    assert main(["--version"]) == 0
    assert capsys.readouterr().out == f"{prog} {nvrq.__version__}\n"


def _subparsers(parser) -> dict:
    return next(a.choices for a in parser._actions if isinstance(a, argparse._SubParsersAction))


def test_every_annotate_option_has_help_and_says_its_default():
    missing = []
    for name, sub in _subparsers(annotate_parser()).items():
        for a in sub._actions:
            if isinstance(a, argparse._HelpAction) or a.help == argparse.SUPPRESS:
                continue
            where = f"{name} {max(a.option_strings, key=len) if a.option_strings else a.metavar}"
            if not a.help:
                missing.append(f"{where}: no help")
            # an option that takes a value says what it is when not given (or that it is required)
            takes_value = a.option_strings and a.nargs != 0
            if takes_value and not a.required and "default" not in a.help:
                missing.append(f"{where}: no default in {a.help!r}")
            if takes_value and a.required and "required" not in a.help:
                missing.append(f"{where}: not marked required in {a.help!r}")
    assert missing == []


def test_positionals_are_spelled_one_way():
    # a study folder is STUDY wherever a command takes one; every positional is upper case
    seen = {}
    for prog, parser in (("annotate", annotate_parser()), ("analyze", analyze_parser())):
        subs = _subparsers(parser) if prog == "annotate" else {"": parser}
        for name, sub in subs.items():
            for a in sub._actions:
                if not a.option_strings and not isinstance(a, argparse._SubParsersAction):
                    seen[f"{prog} {name} {a.dest}"] = a.metavar
    assert all(m and m == m.upper() for m in seen.values()), seen
    assert {m for k, m in seen.items() if k.endswith(" study")} == {"STUDY"}
    usage = _subparsers(annotate_parser())["serve"].format_usage()
    assert "STUDY" in usage and " study" not in usage


def test_comma_lists_are_shown_as_one_value(capsys):
    # --lower-better takes one comma list (the old space-separated form still parses, with a note)
    usage = analyze_parser().format_usage() + analyze_parser().format_help()
    assert "--lower-better A,B" in usage and "A,B [A,B ...]" not in usage
    assert analyze_parser().parse_args(["r.csv", "--lower-better", "x", "y", "--out", "o"]).lower_better == ["x", "y"]
    assert "deprecated" in capsys.readouterr().err


def test_show_progress_needs_a_terminal(monkeypatch):
    class Stream:
        def __init__(self, tty):
            self.tty = tty

        def isatty(self):
            return self.tty

    for tty, quiet, want in ((True, False, True), (True, True, False), (False, False, False)):
        monkeypatch.setattr(sys, "stderr", Stream(tty))
        assert show_progress(argparse.Namespace(quiet=quiet)) is want
    monkeypatch.setattr(sys, "stderr", Stream(True))
    assert show_progress(argparse.Namespace()) is True  # a command without --quiet


def _synth(out: Path, *, stderr_tty: bool) -> str:
    """``nvrq synth`` of a tiny clip; its stderr, from a pipe or from a pseudo-terminal."""
    argv = [sys.executable, "-m", "nvrq.cli", "synth", str(out), "--seconds", "0.4", "--fps", "5",
            "--size", "160x96", "--offsets", "0,1"]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    if not stderr_tty:
        proc = subprocess.run(argv, capture_output=True, text=True, env=env, timeout=300)
        assert proc.returncode == 0, proc.stderr
        return proc.stderr
    main_fd, tty_fd = pty.openpty()
    # a terminal 100 columns wide (a new pseudo-terminal is 0 wide: tqdm would draw nothing)
    fcntl.ioctl(tty_fd, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=tty_fd, env=env)
    os.close(tty_fd)
    chunks = []
    while True:
        try:
            data = os.read(main_fd, 4096)
        except OSError:  # the terminal closed with the process
            break
        if not data:
            break
        chunks.append(data)
    os.close(main_fd)
    assert proc.wait(timeout=300) == 0
    return b"".join(chunks).decode(errors="replace")


def test_progress_bars_only_on_a_terminal(tmp_path):
    # tqdm draws "synth CLIP: 100%|...| n/n [...]" on stderr; a pipe or a log file gets none
    bar = "synth "
    on_tty = _synth(tmp_path / "a", stderr_tty=True)
    assert bar in on_tty and "%|" in on_tty
    piped = _synth(tmp_path / "b", stderr_tty=False)
    assert "%|" not in piped and bar not in piped
