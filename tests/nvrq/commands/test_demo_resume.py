"""An interrupted ``nvrq demo`` is resumed on the same folder: the finished steps are skipped,
the interrupted one starts again on a clean slate; ``--restart`` starts over; a folder that is
no demo's is never emptied.

The steps are stand-ins (``nvrq.commands.demo._entry`` patched) that behave as the real commands
do where it matters here: each writes its outputs (``--out``, the scene or study folder) and
refuses to start when one of them exists already (as ``synth`` and ``build`` refuse a folder with
files in it). Ctrl-C is the step raising KeyboardInterrupt, which the real commands' ``run_cli``
turns into status 130.
"""

from __future__ import annotations

from pathlib import Path

import nvrq.commands.demo as demo
from nvrq.cli import main

OPTS = ["--seconds", "1", "--size", "480x270"]


class FakeSteps:
    """The demo's programs, recording each step they run; ``interrupt`` names a subcommand that
    is interrupted (once) after writing half of its output."""

    def __init__(self, interrupt: str | None = None):
        self.ran: list[str] = []
        self.interrupt = interrupt

    def __call__(self, program):
        def step(argv):
            outs = [Path(argv[argv.index("--out") + 1])] if "--out" in argv else []
            if argv[0] in ("synth", "build"):
                outs.append(Path(argv[1]))
            if any(p.exists() for p in outs):
                print(f"error: {outs[0]}: expected a new output, got an existing one")
                return 2
            self.ran.append("analyze" if program == "analyze" else argv[0])
            for p in outs:
                if p.suffix:
                    p.write_text("half" if argv[0] == self.interrupt else "done")
                else:
                    p.mkdir()
                    (p / "part").write_text("x")
            if argv[0] == "simulate":
                (Path(argv[1]) / "votes").write_text("some votes")
            if argv[0] == self.interrupt:
                self.interrupt = None
                raise KeyboardInterrupt
            return 0
        return step


def _run(monkeypatch, fake, out, *extra):
    monkeypatch.setattr(demo, "_entry", fake)
    return main(["demo", str(out), *OPTS, *extra])


def test_interrupted_demo_resumes_at_the_interrupted_step(tmp_path, monkeypatch, capsys):
    out = tmp_path / "demo"
    fake = FakeSteps(interrupt="score")
    assert _run(monkeypatch, fake, out) == 130
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("interrupted: step 3 of 11 did not finish"), err
    assert f"run nvrq demo {out} with the same options to resume it there" in err[0]
    assert "add --restart to start again" in err[0]
    assert fake.ran == ["synth", "pairs", "score"]
    assert (out / "metrics.csv").read_text() == "half"
    fake.ran.clear()
    assert _run(monkeypatch, fake, out) == 0
    printed = capsys.readouterr().out
    assert "steps 1-2 of 11 finished before, step 3 starts again" in printed
    # synth and pairs are not run again; score starts on a clean slate (its half table removed)
    # (then the torch timing run, the viewpoint floor's scene, its pairs and scores, the study)
    assert fake.ran == ["score", "score", "synth", "pairs", "score", "build", "simulate", "export", "analyze"]
    assert (out / "metrics.csv").read_text() == "done" and (out / "scene" / "part").is_file()
    fake.ran.clear()
    assert _run(monkeypatch, fake, out) == 0  # a finished demo: nothing runs again
    assert fake.ran == [] and "every step finished before" in capsys.readouterr().out


def test_a_step_that_changes_an_earlier_output_goes_back_to_it(tmp_path, monkeypatch, capsys):
    # simulate adds votes to the study in place: an interrupted simulate rebuilds the study first
    out = tmp_path / "demo"
    fake = FakeSteps(interrupt="simulate")
    assert _run(monkeypatch, fake, out) == 130
    fake.ran.clear()
    assert _run(monkeypatch, fake, out) == 0
    assert fake.ran == ["build", "simulate", "export", "analyze"]
    assert (out / "study" / "votes").read_text() == "some votes"


def test_other_options_are_refused_and_restart_starts_over(tmp_path, monkeypatch, capsys):
    out = tmp_path / "demo"
    fake = FakeSteps(interrupt="pairs")
    assert _run(monkeypatch, fake, out) == 130
    capsys.readouterr()
    monkeypatch.setattr(demo, "_entry", fake)
    assert main(["demo", str(out), "--seconds", "2", "--size", "480x270"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--restart" in err[0] and "--seconds 1" in err[0], err
    fake.ran.clear()
    assert main(["demo", str(out), "--seconds", "2", "--size", "480x270", "--restart"]) == 0
    assert fake.ran[:3] == ["synth", "pairs", "score"]


def test_a_folder_that_is_no_demo_is_refused_and_kept(tmp_path, monkeypatch, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    fake = FakeSteps()
    for extra in ([], ["--restart"]):
        assert _run(monkeypatch, fake, out, *extra) == 2
        err = capsys.readouterr().err
        assert "the folder of an interrupted nvrq demo" in err and err.count("\n") == 1
        assert fake.ran == [] and (out / "notes.txt").read_text() == "mine"


def test_a_failed_step_says_how_to_resume(tmp_path, monkeypatch, capsys):
    out = tmp_path / "demo"
    fake = FakeSteps()
    real = fake.__call__
    failed = []

    def entry(program):
        step = real(program)

        def once(argv):
            if argv[0] == "export" and not failed:
                failed.append(argv[0])
                return 2
            return step(argv)
        return once

    monkeypatch.setattr(demo, "_entry", entry)
    assert main(["demo", str(out), *OPTS]) == 2
    assert (f"step 10 failed with status 2; once its input is fixed, nvrq demo {out} with the same "
            "options resumes at this step") in capsys.readouterr().out
    fake.ran.clear()
    assert main(["demo", str(out), *OPTS]) == 0
    assert fake.ran == ["export", "analyze"]
