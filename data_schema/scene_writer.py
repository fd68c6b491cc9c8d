"""The one scene writer (data_schema layer): a typed new scene -> ``scene.json`` + ``images.csv``.

Every importer (``nvrq import nurec|kitti|drivestudio``, :mod:`nvrq.sources.base`) reads its
source into a :class:`NewScene` (cameras, rig trajectory, tracks and the GT frames, with the
file each frame comes from) and hands it here. :func:`scene_images` lists the GT images and one
render row per frame and view; :func:`write_scene` checks the document and the table exactly as
:func:`data_schema.scene.load_scene` will read them back (one line naming ``OUT/scene.json`` or
``OUT/images.csv`` and the field, nothing written), then writes the whole folder through
:class:`data_schema.tables.atomic_folder`: an existing scene folder at ``out`` is replaced as a
whole (no file of the old scene stays), a failure leaves it as it was.

Convention: as :mod:`data_schema.scene` (``T_a_b`` maps frame ``a`` to frame ``b``; poses
``[x, y, z, qx, qy, qz, qw]``; integer microseconds). Views are ``(K, 6)`` rows
``dx, dy, dz`` (metres), ``roll, pitch, yaw`` (degrees), rig frame (docs/FORMATS.md §9).
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from data_schema.errors import InputError
from data_schema.perturbation import PERTURBATION_COLUMNS, extra_columns
from data_schema.scene import (
    FORMAT,
    VERSION,
    CameraCalib,
    SourceWorld,
    Track,
    _jsonable,
    check_images_table,
    save_scene,
    scene_parts,
)
from data_schema.tables import IMAGES_COLUMNS, atomic_folder

__all__ = ["SceneFrame", "NewScene", "scene_doc", "scene_images", "write_scene"]


@dataclass(frozen=True)
class SceneFrame:
    """One GT image of a new scene: ``camera`` at ``timestamp_us``, written at ``path``
    (relative to the scene folder) from ``file`` (None: listed only, the user supplies it).

    Attributes
    ----------
    camera : str
        The camera's name.
    timestamp_us : int
        The image's timestamp, in microseconds.
    path : str
        Where the image is written, relative to the scene folder.
    file : Path or None
        The source image file; None: listed only.
    """

    camera: str
    timestamp_us: int
    path: str
    file: Path | None = None


@dataclass(frozen=True)
class NewScene:
    """A scene read from a source, before it is written (docs/FORMATS.md §2).

    ``cameras``: name -> :class:`~data_schema.scene.CameraCalib` (``T_sensor_rig (4, 4)``, model
    dict); ``rig_timestamps_us (F,)`` int and ``T_rig_world (F, 4, 4)``; ``tracks``: list of
    :class:`~data_schema.scene.Track`; ``frames``: the GT images (:class:`SceneFrame`).

    Attributes
    ----------
    clip_id : str
        Written as ``scene.json``'s ``clip_id`` (non-empty, without ':').
    cameras : dict of str to CameraCalib
        Camera name -> calibration, for ``scene.json``'s ``cameras``.
    rig_timestamps_us : (F,) int ndarray
        Rig pose times, microseconds.
    T_rig_world : (F, 4, 4) float ndarray
        The rig pose (rig -> world) at each of those times.
    tracks : list of Track
        Object box tracks for ``scene.json``'s ``tracks``.
    frames : list of SceneFrame
        The GT images the writer lists in ``images.csv``.
    attributes : dict of str to str
        Free-form labels for ``scene.json`` (e.g. weather).
    source_world : SourceWorld or None
        The source tool's own world, when it has one; else None.
    """

    clip_id: str
    cameras: dict[str, CameraCalib]
    rig_timestamps_us: np.ndarray
    T_rig_world: np.ndarray
    tracks: list[Track]
    frames: list[SceneFrame]
    attributes: dict[str, str] = field(default_factory=dict)
    source_world: SourceWorld | None = None


def scene_doc(scene: NewScene) -> dict:
    """The ``scene.json`` document of ``scene`` (numpy arrays as lists).

    Parameters
    ----------
    scene : NewScene
        The scene.

    Returns
    -------
    dict
        ``format``, ``version``, ``clip_id``, ``attributes``, ``cameras``, ``rig_trajectory``,
        ``tracks`` and, when set, ``source_world`` (docs/FORMATS.md §2).
    """
    doc = {
        "format": FORMAT, "version": VERSION, "clip_id": scene.clip_id, "attributes": dict(scene.attributes),
        "cameras": {n: {"T_sensor_rig": np.asarray(c.T_sensor_rig, float), "model": c.model}
                    for n, c in scene.cameras.items()},
        "rig_trajectory": {"timestamps_us": np.asarray(scene.rig_timestamps_us, np.int64),
                           "T_rig_world": np.asarray(scene.T_rig_world, float)},
        "tracks": [{"track_id": t.track_id, "label_class": t.label_class, "dims_lwh": np.asarray(t.dims_lwh, float),
                    "timestamps_us": np.asarray(t.timestamps_us, np.int64), "poses": np.asarray(t.poses, float),
                    **({} if getattr(t, "source_visibility", None) is None
                       else {"source_visibility": list(t.source_visibility)})}
                   for t in scene.tracks],
    }
    if scene.source_world is not None:
        sw = scene.source_world
        doc["source_world"] = {"name": sw.name, "dataset": sw.dataset, "T_world_source": sw.T_world_source}
    return json.loads(json.dumps(doc, default=_jsonable))


def scene_images(scene: NewScene, views, render_path: Callable) -> pd.DataFrame:
    """The ``images.csv`` rows of ``scene``: each GT frame, then one render per view.

    Parameters
    ----------
    scene : NewScene
        The scene (its ``frames`` in order).
    views : array_like, (K, 6)
        The views to render (docs/FORMATS.md §9); duplicates are listed once.
    render_path : callable
        ``render_path(camera, timestamp_us, view (6,)) -> str``, the render's path in the scene.

    Returns
    -------
    pandas.DataFrame
        :data:`~data_schema.tables.IMAGES_COLUMNS`, then the perturbation columns the views use.
    """
    views = np.asarray(views, float).reshape(-1, 6)
    rows = []
    for f in scene.frames:
        rows.append((f.camera, int(f.timestamp_us), "gt", *[0.0] * 6, f.path))
        rows += [(f.camera, int(f.timestamp_us), "render", *v.tolist(), render_path(f.camera, int(f.timestamp_us), v))
                 for v in views]
    images = pd.DataFrame(rows, columns=["camera", "timestamp_us", "source", *PERTURBATION_COLUMNS, "path"])
    images = images.drop_duplicates(["camera", "timestamp_us", "source", *PERTURBATION_COLUMNS])
    return images.loc[:, [*IMAGES_COLUMNS, *extra_columns(views)]].reset_index(drop=True)


def _check(scene: NewScene, images: pd.DataFrame, out: Path) -> dict:
    """Check what :func:`write_scene` would write, as :func:`load_scene` reads it; the document."""
    if not isinstance(scene, NewScene):
        raise InputError(param="scene", expected="a NewScene", got=type(scene).__name__)
    try:
        doc = scene_doc(scene)
    except (TypeError, ValueError) as exc:
        raise InputError(out / "scene.json", None, "a JSON document", str(exc)) from None
    parts = scene_parts(doc, str(out / "scene.json"))
    check_images_table(images, out, parts["cameras"], where=str(out / "images.csv"))
    listed = set(images.path)
    for f in scene.frames:
        if f.path not in listed:
            raise InputError(out / "images.csv", "column path", f"a row for the GT image {f.path}", "none")
        if f.file is not None and not Path(f.file).is_file():
            raise InputError(f.file, None, f"the GT image for {f.path}", "no such file")
    return doc


def _place(src: Path, dst: Path, *, link: bool, where: Path) -> None:
    dst.parent.mkdir(parents=True, exist_ok=True)
    try:
        os.symlink(os.path.abspath(src), dst) if link else shutil.copyfile(src, dst)
    except OSError as exc:
        raise InputError(where, None, "a writable output (with symbolic links, or a copy)",
                         exc.strerror or type(exc).__name__) from None


def write_scene(scene: NewScene, out, *, images: pd.DataFrame, link: bool = False, files=None) -> Path:
    """Check ``scene`` and ``images``, then write the scene folder ``out`` whole and atomically.

    Parameters
    ----------
    scene : NewScene
        The scene; each frame with a ``file`` gets it copied (or linked) to its ``path``.
    out : str or os.PathLike
        The scene folder; an existing one is replaced as a whole, nothing of it stays.
    images : pandas.DataFrame
        The ``images.csv`` rows (:func:`scene_images`); every frame's ``path`` among them.
    link : bool
        Absolute symbolic links to the frames' files instead of copies.
    files : dict of str to path, optional
        More files to place as the frames' are: path in the scene (listed in ``images``) -> the
        existing file (e.g. a real photograph used as a render).

    Returns
    -------
    pathlib.Path
        The scene folder written, ``out`` as given.

    Raises
    ------
    InputError
        A field of the scene or a row of the table that :func:`data_schema.scene.load_scene`
        would refuse (naming ``out/scene.json`` or ``out/images.csv``), a missing frame file, or
        an unwritable output. Nothing is written then.
    """
    out = Path(out)
    doc = _check(scene, images, out)
    files = dict(files or {})
    listed = set(images.path)
    for rel, src in files.items():
        if rel not in listed or not Path(src).is_file():
            raise InputError(src, None, f"an existing file listed in images.csv as {rel}",
                             "no such file" if rel in listed else "not listed")
    with atomic_folder(out) as tmp:
        for rel, src in [*((f.path, f.file) for f in scene.frames), *files.items()]:
            if src is not None and not (tmp / rel).exists():  # one file can back several rows
                _place(Path(src), tmp / rel, link=link, where=out / rel)
        save_scene(doc, images, tmp)
    return out
