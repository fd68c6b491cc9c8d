"""Stage, then swap: how ``nvrq import renders`` changes a scene so that a kill at any moment
leaves either the scene as it was or a journal that the next import finishes (library layer,
used by :mod:`nvrq.sources.renders`).

1. **Stage.** Every new render file is copied (or linked) under ``SCENE/.nvrq-import/files/``
   at its scene path, and the new ``images.csv`` is written to ``SCENE/.nvrq-import/``. The
   scene itself is untouched: a kill here leaves a staging folder without a journal, which the
   next import deletes.
2. **Commit.** ``SCENE/.nvrq-import/journal.json`` (the list of staged files) is written
   atomically: from then on the import counts as done.
3. **Swap.** Each staged file is renamed over its scene path (``os.replace``, atomic per file,
   same file system), then ``images.csv``; the staging folder goes last, its journal after the
   files. A kill here leaves the journal: :func:`finish_interrupted` (run first by every import)
   renames what is still staged, which gives the scene the uninterrupted import would have
   given; until then :func:`data_schema.scene.load_scene` refuses the scene in one line, so
   nothing reads a half-swapped scene.
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Callable
from pathlib import Path

from data_schema.scene import IMPORT_STAGING
from data_schema.tables import atomic_write_text

__all__ = ["JOURNAL", "finish_interrupted", "stage_and_swap"]

#: The journal of a committed import, inside the staging folder.
JOURNAL = "journal.json"


def _swap(root: Path, stage: Path, files: list[str]) -> None:
    """Rename every staged file still there over its scene path, then images.csv; drop the stage."""
    for rel in files:
        src = stage / "files" / rel
        if os.path.lexists(src):  # moved already by an interrupted swap otherwise
            dst = root / rel
            dst.parent.mkdir(parents=True, exist_ok=True)
            os.replace(src, dst)
    if (stage / "images.csv").exists():
        os.replace(stage / "images.csv", root / "images.csv")
    shutil.rmtree(stage / "files", ignore_errors=True)
    (stage / JOURNAL).unlink(missing_ok=True)  # after the files: the journal goes last
    shutil.rmtree(stage, ignore_errors=True)


def finish_interrupted(root) -> str | None:
    """Finish a committed import that was interrupted, or discard an uncommitted staging folder.

    Parameters
    ----------
    root : path
        The scene folder.

    Returns
    -------
    str or None
        ``'finished'`` (the journal's swap completed), ``'discarded'`` (staged files of an
        import killed before its commit deleted; the scene was untouched) or None (nothing to do).
    """
    root = Path(root)
    stage = root / IMPORT_STAGING
    if not stage.is_dir():
        return None
    journal = stage / JOURNAL
    if journal.is_file():
        _swap(root, stage, json.loads(journal.read_text(encoding="utf-8"))["files"])
        return "finished"
    shutil.rmtree(stage)
    return "discarded"


def stage_and_swap(root, files: dict[str, Callable[[Path], None]], write_images: Callable[[Path], None]) -> None:
    """Stage every file and the new ``images.csv``, commit, then swap them into the scene ``root``.

    Parameters
    ----------
    root : path
        The scene folder (no staging folder in it: :func:`finish_interrupted` first).
    files : dict of str to callable
        Scene path (relative) -> ``put(path)``, which writes (copies or links) the file at ``path``.
    write_images : callable
        ``write_images(folder)`` writes the new ``images.csv`` into ``folder``.

    Raises
    ------
    OSError
        A file could not be staged (the staging folder is removed, the scene is untouched).
    """
    root = Path(root)
    stage = root / IMPORT_STAGING
    try:
        for rel, put in files.items():
            path = stage / "files" / rel
            path.parent.mkdir(parents=True, exist_ok=True)
            put(path)
        write_images(stage)
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    atomic_write_text(stage / JOURNAL, json.dumps({"files": sorted(files)}))  # the commit
    _swap(root, stage, sorted(files))
