"""Output-path safety: no command overwrites its inputs or the folders the toolkit manages.

The rule, the same for every command that writes (docs/FORMATS.md §7):

1. An output is never one of the command's inputs (same path, a link to it, or a folder that
   holds an input).
2. An output never lies inside a *managed folder*: a scene folder (it holds ``scene.json``)
   or a study folder (it holds ``manifest.json``). Those folders are written only by the
   command that makes them (``nvrq synth``/``nvrq import`` and ``annotate build``).
3. An output file never replaces a folder.
4. A report folder (``analyze --out``, ``nvrq stability --out``) may replace only a previous
   report folder *of the same command*, recognised by the marker file :data:`REPORT_MARKER`
   written into every report folder, which names the command that made it (``analyze``,
   ``stability``) and the inputs it was made from; an empty or absent folder is fine; anything
   else (another command's report, other files) is refused. A marker without a command (written
   before the marker named one) may be replaced by either command. Replacing a report made from
   other inputs is allowed and says so: :func:`replacing_note` gives the line the command prints.
5. A new scene folder (``nvrq synth``, ``nvrq import``) may replace only a previous scene
   folder; a new study folder must be absent or empty (votes are never overwritten).

Each check raises :class:`~data_schema.errors.InputError` naming the option (``where``) and
returns the output path. ``option`` is the parameter named (default ``out``), which the CLIs
report as their flag (:func:`nvrq.cli_types.flags_in_errors`).

>>> import tempfile
>>> d = Path(tempfile.mkdtemp()); _ = (d / "pairs.csv").write_text("x")
>>> check_output_file(d / "pairs.csv", inputs=[d / "pairs.csv"])
Traceback (most recent call last):
...
data_schema.errors.InputError: out: expected an output path that is not an input, got the input pairs.csv
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable
from pathlib import Path

from data_schema.errors import InputError

__all__ = [
    "REPORT_MARKER",
    "SCENE_FILE",
    "STUDY_FILE",
    "REPORT_COMMANDS",
    "managed_folder",
    "check_output_file",
    "check_output_folder",
    "mark_report",
    "report_marker",
    "replacing_note",
]

#: The marker file in every report folder written by the toolkit.
REPORT_MARKER = ".nvrq-report"
#: A folder holding this file is a scene folder (docs/FORMATS.md §2).
SCENE_FILE = "scene.json"
#: A folder holding this file is a study folder (``annotate build``).
STUDY_FILE = "manifest.json"

_KINDS = {SCENE_FILE: "scene", STUDY_FILE: "study"}
#: The commands that write report folders (the ``command`` of :data:`REPORT_MARKER`).
REPORT_COMMANDS = ("analyze", "stability")
MARKER_VERSION = 2


def _resolve(path) -> Path:
    return Path(os.path.abspath(os.path.expanduser(str(path)))).resolve()


def managed_folder(path) -> tuple[Path, str] | None:
    """The nearest scene or study folder at or above ``path``: ``(folder, 'scene'|'study')``.

    Parameters
    ----------
    path : str or path-like
        A file or folder path (``~`` expanded, resolved).

    Returns
    -------
    tuple of (Path, str) or None
        The folder and its kind, ``'scene'`` or ``'study'``; None when there is none.
    """
    p = _resolve(path)
    for folder in (p, *p.parents):
        for name, kind in _KINDS.items():
            if (folder / name).is_file():
                return folder, kind
    return None


def _same(a: Path, b: Path) -> bool:
    if a == b:
        return True
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def _check_inputs(out: Path, inputs: Iterable, option: str) -> None:
    for inp in inputs:
        if inp is None:
            continue
        ip = _resolve(inp)
        if _same(out, ip):
            raise InputError(param=option, expected="an output path that is not an input",
                             got=f"the input {Path(inp).name}")
        if out in ip.parents:
            raise InputError(param=option, expected="an output folder that holds none of the inputs",
                             got=f"a folder holding the input {Path(inp).name}")


def _check_not_managed(out: Path, option: str, *, allow: Path | None = None) -> None:
    found = managed_folder(out.parent if allow is not None and out == allow else out)
    if found is not None and found[0] != allow:
        folder, kind = found
        raise InputError(param=option, expected=f"a path outside the {kind} folder {folder} (the toolkit manages it)",
                         got=str(out))


def check_output_file(out, *, inputs: Iterable = (), option: str = "out") -> Path:
    """Check an output file path against the rule (module docstring).

    Parameters
    ----------
    out : str or os.PathLike
        The output file.
    inputs : iterable of paths
        The command's inputs (None entries are skipped).
    option : str
        The parameter named in errors (its ``param``; the CLIs show their flag).

    Returns
    -------
    pathlib.Path
        ``out`` as given, once it obeys the rule (else :class:`InputError`).
    """
    target = _resolve(out)
    if target.is_dir():
        raise InputError(param=option, expected="an output file path", got=f"{out} (an existing folder)")
    _check_inputs(target, inputs, option)
    _check_not_managed(target, option)
    return Path(out)


def _is_empty_dir(p: Path) -> bool:
    return p.is_dir() and not any(p.iterdir())


def _check_report_command(target: Path, out, command: str | None, option: str) -> None:
    """Refuse a report folder made by another command than ``command`` (rule 4)."""
    if command is None:
        return
    made_by = (report_marker(target) or {}).get("command")
    if made_by is not None and made_by != command:
        raise InputError(param=option, expected=f"an absent or empty folder, or a report folder of {command}'s",
                         got=f"{out} (a report folder of {made_by}'s; choose another folder)")


def check_output_folder(out, *, kind: str, inputs: Iterable = (), option: str = "out",
                        command: str | None = None) -> Path:
    """Check the output folder ``out`` of ``kind`` against the rule (module docstring).

    Parameters
    ----------
    out : str or os.PathLike
        The output folder.
    kind : {'report', 'scene', 'study'}
        What the command writes: ``report`` may replace an empty folder or a report folder of
        ``command``'s; ``scene`` an empty folder or a scene folder; ``study`` only an empty one.
    inputs : iterable of paths
        The command's inputs (None entries are skipped).
    option : str
        The parameter named in errors.
    command : {'analyze', 'stability'}, optional
        The command writing a report (default: any report folder of ours may be replaced).

    Returns
    -------
    pathlib.Path
        ``out`` as given, once it obeys the rule (else :class:`InputError`; an unknown ``kind``
        too).
    """
    if kind not in ("report", "scene", "study"):
        raise InputError(param="kind", expected="one of {'report', 'scene', 'study'}", got=kind)
    target = _resolve(out)
    if target.exists() and not target.is_dir():
        raise InputError(param=option, expected=f"a {kind} folder", got=f"{out} (an existing file)")
    _check_inputs(target, inputs, option)
    own = None
    if target.is_dir() and not _is_empty_dir(target):
        if kind == "report" and (target / REPORT_MARKER).is_file():
            _check_report_command(target, out, command, option)
        elif kind == "scene" and (target / SCENE_FILE).is_file():
            own = target
        else:
            what = {"report": f"an absent or empty folder, or a report folder of ours (with {REPORT_MARKER})",
                    "scene": "an absent or empty folder, or a previous scene folder",
                    "study": "a new or empty study folder (votes are never overwritten)"}[kind]
            raise InputError(param=option, expected=what, got=f"{out} (a folder with other files)")
    _check_not_managed(target, option, allow=own)
    return Path(out)


def _input_record(inputs: dict | None) -> dict:
    """``inputs`` as JSON: option -> absolute path(s) or values, as strings; None entries dropped."""
    record = {}
    for key, value in (inputs or {}).items():
        values = value if isinstance(value, (list, tuple)) else [value]
        values = [os.path.abspath(str(v)) if isinstance(v, (Path, os.PathLike)) else str(v)
                  for v in values if v is not None]
        if values:
            record[str(key)] = values
    return record


def mark_report(folder, *, command: str | None = None, inputs: dict | None = None) -> Path:
    """Write the report marker into ``folder`` (see :func:`check_output_folder`).

    Parameters
    ----------
    folder : str or os.PathLike
        The report folder (or the temporary folder that becomes it).
    command : {'analyze', 'stability'}, optional
        The command that made the report (a later run of another command will not replace it).
    inputs : dict, optional
        What it was made from: option -> value or list of values (paths as
        :class:`pathlib.Path`, recorded absolute; other values as text).

    Returns
    -------
    pathlib.Path
        The marker file.
    """
    path = Path(folder) / REPORT_MARKER
    doc = {"format": "nvrq-report", "version": MARKER_VERSION, "command": command, "inputs": _input_record(inputs)}
    path.write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    return path


def report_marker(folder) -> dict | None:
    """The marker of the report folder ``folder`` as a dict (``{}`` for an unreadable one), or
    None when it has none.

    Parameters
    ----------
    folder : str or os.PathLike
        A folder.

    Returns
    -------
    dict or None
        ``format``, ``version`` and, from version 2, ``command`` and ``inputs``.
    """
    path = Path(folder) / REPORT_MARKER
    if not path.is_file():
        return None
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return doc if isinstance(doc, dict) else {}


def replacing_note(out, *, command: str, inputs: dict | None) -> str | None:
    """The note a command prints before it replaces the report ``out`` made from other inputs.

    Parameters
    ----------
    out : str or os.PathLike
        The report folder about to be written.
    command : str
        The command writing it.
    inputs : dict
        What the new report is made from (as :func:`mark_report` takes it).

    Returns
    -------
    str or None
        ``"note: replacing the report OUT made from other inputs: --stability added; ..."``,
        or None when ``out`` holds no report of ours, or one made from the same inputs.
    """
    old = report_marker(_resolve(out))
    if old is None:
        return None
    before = old.get("inputs") if isinstance(old.get("inputs"), dict) else None
    after = _input_record(inputs)
    if before is None:
        return f"note: replacing the report {out} (its marker does not record its inputs)"
    changes = []
    for key in sorted(set(before) | set(after)):
        if key not in before:
            changes.append(f"{key} added ({', '.join(after[key])})")
        elif key not in after:
            changes.append(f"{key} dropped (was {', '.join(before[key])})")
        elif before[key] != after[key]:
            changes.append(f"{key} changed (was {', '.join(before[key])})")
    if not changes:
        return None
    return f"note: replacing the report {out} made by {old.get('command') or command} from other inputs: " \
        + "; ".join(changes)
