"""Resuming an interrupted ``nvrq demo`` (commands layer).

The demo keeps a record, ``OUT/demo.json``: the options its steps depend on, the steps that
finished, and for the step running, the entries of ``OUT`` that existed before it started.
Run again with the same options on that folder, the demo skips the finished steps and starts
again at the first unfinished one, after removing what that step had begun to write (the
entries of ``OUT`` it added). A step that changes an earlier step's output in place
(``annotate simulate`` adds votes to the study that ``annotate build`` made) goes back to that
earlier step. ``--restart`` empties the folder of a demo and starts it again; a folder that
holds no demo record is never emptied.

>>> steps = [("nvrq", ["synth", "o/scene"]), ("annotate", ["build", "o/study"]),
...          ("annotate", ["simulate", "o/study", "--raters", "5"])]
>>> first_step_to_run(steps, done=[1, 2])  # simulate, unfinished, needs a fresh study
2
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from data_schema.errors import InputError

__all__ = ["RECORD", "DemoRecord", "first_step_to_run", "OPTIONS"]

#: the demo's record in its output folder
RECORD = "demo.json"
#: the options of ``nvrq demo`` that its steps depend on (a resumed demo must keep them)
OPTIONS = ("seed", "seconds", "size", "offsets", "encoder", "raters", "methods")
#: steps (program, subcommand) that change the output of an earlier step in place -> that
#: step's subcommand
_IN_PLACE = {("annotate", "simulate"): "build"}


def first_step_to_run(steps: list[tuple[str, list[str]]], done: list[int]) -> int:
    """The 1-based index of the first step a resumed demo runs.

    Parameters
    ----------
    steps : list of (str, list of str)
        The demo's steps, ``(program, argv)``.
    done : list of int
        The 1-based indices of the steps that finished.

    Returns
    -------
    int
        The first unfinished step, or the earlier step whose output it changes in place
        (``len(steps) + 1`` when every step finished).
    """
    first = next((i for i in range(1, len(steps) + 1) if i not in set(done)), len(steps) + 1)
    if first <= len(steps):
        program, argv = steps[first - 1]
        source = _IN_PLACE.get((program, argv[0]))
        if source is not None:
            for j in range(first - 1, 0, -1):
                if steps[j - 1][0] == program and steps[j - 1][1][0] == source:
                    return j
    return first


class DemoRecord:
    """The record of one demo folder (module docstring).

    Parameters
    ----------
    out : pathlib.Path
        The demo's output folder.
    options : dict
        The demo's options (:data:`OPTIONS`), as given this time.
    """

    def __init__(self, out: Path, options: dict):
        self.out, self.path = Path(out), Path(out) / RECORD
        self.options = {k: options[k] for k in OPTIONS}
        self.done: list[int] = []
        self.running: int | None = None
        self.before: list[str] = []

    @classmethod
    def open(cls, out: Path, args, *, restart: bool) -> DemoRecord:
        """The record of ``out`` for a demo with ``args``: new for an empty or absent folder,
        read back to resume an interrupted demo, or new after ``restart`` emptied the folder.

        Parameters
        ----------
        out : pathlib.Path
            The output folder.
        args : argparse.Namespace
            ``nvrq demo``'s options.
        restart : bool
            Empty a demo's folder and start again.

        Returns
        -------
        DemoRecord
            Its ``done`` lists the finished steps (empty for a new demo).

        Raises
        ------
        InputError
            ``out`` holds files but no demo record; or a record of other options, without
            ``restart``.
        """
        rec = cls(out, {k: getattr(args, k) for k in OPTIONS})
        if not out.exists() or not any(out.iterdir()):
            out.mkdir(parents=True, exist_ok=True)
            rec.save()
            return rec
        if not rec.path.is_file():
            raise InputError(out, None, "an empty or absent output folder, or the folder of an "
                             "interrupted nvrq demo (to resume it)", "a folder with other files in it")
        try:
            saved = json.loads(rec.path.read_text(encoding="utf-8"))
            options, done = saved["options"], [int(i) for i in saved["done"]]
        except (ValueError, KeyError, TypeError):
            raise InputError(rec.path, None, "the record of an nvrq demo", "an unreadable file") from None
        if restart:
            for entry in out.iterdir():
                _remove(entry)
            rec.save()
            return rec
        if options != rec.options:
            diff = [f"--{k.replace('_', '-')} {options.get(k)}" for k in OPTIONS if options.get(k) != rec.options[k]]
            raise InputError(out, None, "the options of the demo that was interrupted there, to resume it "
                             "(or --restart to start it again with these)",
                             "a demo run with " + ", ".join(diff))
        rec.done, rec.running, rec.before = done, saved.get("running"), list(saved.get("before", []))
        return rec

    def resume_at(self, steps: list[tuple[str, list[str]]]) -> int:
        """Prepare the folder for the first step to run (:func:`first_step_to_run`): remove
        what the steps from there on had begun to write, and forget that they finished.

        Parameters
        ----------
        steps : list of (str, list of str)
            The demo's steps.

        Returns
        -------
        int
            The 1-based index of the first step to run.
        """
        first = first_step_to_run(steps, self.done)
        if first > len(steps):
            return first
        if self.running is not None and self.running >= first:
            keep = set(self.before) | {RECORD}
            for entry in self.out.iterdir():
                if entry.name not in keep:
                    _remove(entry)
        for i in range(first, len(steps) + 1):
            for path in _outputs(steps[i - 1]):
                if path.parent == self.out and path.exists():
                    _remove(path)
        self.done = [i for i in self.done if i < first]
        self.running = None
        self.save()
        return first

    def begin(self, step: int) -> None:
        """Record that ``step`` starts, with the entries of the folder before it."""
        self.running = step
        self.before = sorted(e.name for e in self.out.iterdir() if e.name != RECORD)
        self.save()

    def finish(self, step: int) -> None:
        """Record that ``step`` finished."""
        self.done, self.running, self.before = sorted({*self.done, step}), None, []
        self.save()

    def save(self) -> None:
        """Write the record (atomically)."""
        from data_schema.tables import atomic_write_text  # pandas: not on nvrq --help's path

        atomic_write_text(self.path, json.dumps({"options": self.options, "done": self.done,
                                                 "running": self.running, "before": self.before},
                                                indent=1) + "\n")


def _outputs(step: tuple[str, list[str]]) -> list[Path]:
    """What a step writes: its ``--out`` and, for the commands that make a folder (synth,
    build), their first argument; ``score``'s timing table beside its output."""
    program, argv = step
    out = [Path(argv[argv.index("--out") + 1])] if "--out" in argv else []
    if argv[0] in ("synth", "build"):
        out.append(Path(argv[1]))
    if argv[0] == "score" and out:
        out.append(out[0].with_name(out[0].stem + ".timing.csv"))
    if "--save-features" in argv:
        out.append(Path(argv[argv.index("--save-features") + 1]))
    return out


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    else:
        path.unlink(missing_ok=True)
