"""The shape every importer shares (nvrq layer): read a source, return an :class:`ImportedScene`.

An importer is one module holding an object that follows :class:`Importer`: its
``read(path, **options)`` takes its source (the file or folder its ``nvrq import NAME``
subcommand names first) and its options as Python values (the subcommand turns its parsed
arguments into them, :class:`nvrq.commands.imports.ImporterCommand`) and returns the typed scene
(:class:`data_schema.scene_writer.NewScene`: cameras, frames, tracks) and the views to plan.
:func:`write_imported` hands both to the one writer, :func:`data_schema.scene_writer.write_scene`,
which checks what it writes and writes the folder whole and atomically. The subcommand itself is
one :class:`nvrq.commands.imports.ImporterCommand` registration, which also names the arguments
that are inputs (so ``nvrq`` refuses an output over them before any work).

>>> imported = ImportedScene(NewScene("c", {}, np.zeros(0, np.int64), np.zeros((0, 4, 4)), [], []),
...                          views=np.zeros((1, 6)))
>>> describe(imported)
'0 frames x 0 cameras, 0 tracks'
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol, runtime_checkable

import numpy as np

from data_schema.methods import METHOD_COLUMN
from data_schema.scene_writer import NewScene, scene_images, write_scene
from data_schema.text import plural
from nvrq.render_plans import default_image_path

__all__ = ["Importer", "ImportedScene", "plan_render_path", "write_imported", "describe"]


def plan_render_path(camera: str, timestamp_us: int, view: np.ndarray) -> str:
    """The render path of a view, :func:`nvrq.render_plans.default_image_path`'s layout.

    Parameters
    ----------
    camera : str
        The camera name.
    timestamp_us : int
        The frame time, microseconds.
    view : numpy.ndarray, (6,)
        ``dx, dy, dz`` metres, ``roll, pitch, yaw`` degrees (a lateral view by its ``dy`` alone).

    Returns
    -------
    str
        e.g. ``images/front/render_+1.00/100000.png``.
    """
    return default_image_path(camera, timestamp_us, "render", float(view[1]), perturbation=view)


@dataclass(frozen=True)
class ImportedScene:
    """What an importer returns: the ``scene``, the ``views (K, 6)`` to plan (rig frame, metres and
    degrees), whether its frames are ``link``-ed rather than copied, one-line ``notes`` for the
    user, a ``detail`` for the closing line (e.g. the dataset) and, when the renders are not at
    :func:`plan_render_path`, the ``render_path(camera, timestamp_us, view)`` to list them at;
    ``method`` names the method of every render row (``''``: none) and ``render_files`` maps
    render paths to the files that exist already (copied into the scene).

    Attributes
    ----------
    scene : NewScene
        The typed scene to write.
    views : (K, 6) float numpy.ndarray
        Views to plan, ``dx, dy, dz, roll, pitch, yaw`` (rig frame, metres and degrees).
    link : bool
        Whether the frames are linked rather than copied (default False).
    notes : tuple of str
        One-line notes for the user.
    detail : str
        Detail for the closing line (e.g. the dataset).
    render_path : callable or None
        ``render_path(camera, timestamp_us, view)`` when the renders are not at
        :func:`plan_render_path`; None otherwise.
    method : str
        The ``method`` of every render row (``''``: no method column).
    render_files : dict of str to Path
        Render path in the scene -> the existing file written there (default: none, the renders
        are to be produced).
    """

    scene: NewScene
    views: np.ndarray
    link: bool = False
    notes: tuple[str, ...] = ()
    detail: str = ""
    render_path: Callable | None = None
    method: str = ""
    render_files: dict = field(default_factory=dict)


@runtime_checkable
class Importer(Protocol):
    """An importer: ``read(path, **options)`` turns a source and its options into an
    :class:`ImportedScene`, checking everything it reads and raising
    :class:`~data_schema.errors.InputError` (one line, naming the file or the parameter) on a
    bad source."""

    def read(self, path, **options) -> ImportedScene:
        """Read and check the source.

        Parameters
        ----------
        path : path
            The source (archive, folder or image) the subcommand names first.
        **options
            The importer's own keywords (its ``read_X`` function's).

        Returns
        -------
        ImportedScene
            The scene and the views to plan.
        """
        ...


def write_imported(imported: ImportedScene, out: str | os.PathLike) -> Path:
    """Write ``imported`` as the scene folder ``out`` through the one writer.

    Parameters
    ----------
    imported : ImportedScene
        What an importer read.
    out : str or os.PathLike
        The scene folder (replaced whole, atomically; nothing written on an error).

    Returns
    -------
    pathlib.Path
        ``out``.
    """
    images = scene_images(imported.scene, imported.views, imported.render_path or plan_render_path)
    if imported.method:
        images[METHOD_COLUMN] = np.where(images["source"] == "render", imported.method, "")
    return write_scene(imported.scene, out, images=images, link=imported.link, files=imported.render_files)


def describe(imported: ImportedScene) -> str:
    """``'[DETAIL: ]F frames x C cameras, T tracks'``, with singular nouns for one.

    Parameters
    ----------
    imported : ImportedScene
        What an importer read.

    Returns
    -------
    str
        The summary printed after ``wrote OUT``.
    """
    scene = imported.scene
    n_frames = len({f.timestamp_us for f in scene.frames}) if scene.cameras else 0
    if scene.cameras:
        per_cam = [sum(f.camera == c for f in scene.frames) for c in scene.cameras]
        n_frames = max(per_cam)
    text = f"{plural(n_frames, 'frame')} x {plural(len(scene.cameras), 'camera')}, " \
           f"{plural(len(scene.tracks), 'track')}"
    return f"{imported.detail}: {text}" if imported.detail else text
