"""Pairs of many clips at once: one Parquet dataset partitioned by ``clip_id``.

Layer: nvrq core, sources to pairs (multi-clip pairs datasets).

``nvrq pairs A B ... --out DATASET/`` (or ``nvrq pairs FLEET/ --out DATASET/`` where FLEET
holds scene folders) runs :func:`nvrq.pairs.make_pairs` clip by clip and writes each clip's
rows, unchanged, to ``DATASET/clip_id=<id>/part-0.parquet`` (layout:
:mod:`data_schema.datasets`). The dataset appears only when every clip is done.

A clip that fails validation stops the run with its one-line error, unless ``keep_going``:
then the good clips are written, with ``DATASET/failed.csv`` (``clip, reason``) beside them,
and the caller exits non-zero. Clips with different attribute names get the union of them
(missing values empty), so every file has one schema; likewise ``method`` (docs/FORMATS.md §2),
empty in the clips without methods when some clip has them.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
from tqdm.auto import tqdm

from data_schema.datasets import DatasetWriter
from data_schema.defaults import MIN_VISIBLE
from data_schema.errors import InputError
from data_schema.methods import METHOD_COLUMN
from data_schema.scene import load_scene
from data_schema.text import plural
from nvrq.pairs import DROP_REASONS, PAIRS_OUTPUT_COLUMNS, PairStats, make_pairs

__all__ = ["find_scenes", "FleetResult", "clip_pairs", "fleet_pairs"]


def find_scenes(paths) -> list[Path]:
    """Scene folders from ``paths``: each is a scene folder (with ``scene.json``) or a folder
    whose sub-folders are scene folders (sorted by name).

    Parameters
    ----------
    paths : iterable of str or Path
        Scene folders, or folders of scene folders.

    Returns
    -------
    list of Path

    Raises
    ------
    InputError
        A path that is neither.
    """
    out = []
    for p in map(Path, paths):
        if (p / "scene.json").is_file():
            out.append(p)
            continue
        if not p.is_dir():
            raise InputError(p, None, "a scene folder or a folder of scene folders", "no such folder")
        subs = sorted(d for d in p.iterdir() if d.is_dir() and (d / "scene.json").is_file())
        if not subs:
            raise InputError(p, None, "a scene folder (scene.json) or a folder of scene folders",
                             "neither")
        out += subs
    return out


@dataclass
class FleetResult:
    """What :func:`fleet_pairs` did: pair counts over all clips, the clips written and the failed.

    Attributes
    ----------
    stats : PairStats
        Pair counts summed over the clips written.
    clips : list of str
        The clip ids written.
    failed : list of (str, str)
        ``(clip, reason)`` of each clip skipped with ``keep_going``.
    """

    stats: PairStats = field(default_factory=PairStats)
    clips: list = field(default_factory=list)
    failed: list = field(default_factory=list)  # (clip, reason)

    def summary(self) -> str:
        line = f"{plural(len(self.clips), 'clip')}: {self.stats.summary()}"
        if self.failed:
            line += f"; {plural(len(self.failed), 'clip')} failed (failed.csv)"
        return line


def _clip_name(scene_dir: Path) -> str:
    try:
        return str(json.loads((scene_dir / "scene.json").read_text(encoding="utf-8"))["clip_id"])
    except (OSError, ValueError, KeyError, TypeError):
        return scene_dir.name


def _add_stats(total: PairStats, s: PairStats) -> None:
    total.candidates += s.candidates
    total.kept += s.kept
    total.frames_outside_trajectory += s.frames_outside_trajectory
    for k in DROP_REASONS:
        total.dropped[k] += s.dropped[k]


def clip_pairs(scene_dir, *, attributes=None, min_side: float, min_area: float, min_visible: float = MIN_VISIBLE,
               progress: bool = False):
    """``(clip_id, pairs, stats)`` of one scene folder: :func:`nvrq.pairs.make_pairs` after
    applying the :class:`nvrq.clip_attributes.ClipAttributes` ``attributes`` (if any).

    Parameters
    ----------
    scene_dir : str or Path
        A scene folder.
    attributes : ClipAttributes, optional
        Clip attributes that override the scene's.
    min_side : float, pixels
        Smallest box side kept.
    min_area : float, pixels
        Smallest box area kept.
    min_visible : float, 0..1, optional
        Smallest visible fraction kept, in both views.
    progress : bool, optional
        Show a progress bar.

    Returns
    -------
    clip_id : str
    pairs : pandas.DataFrame
        The pairs table (docs/FORMATS.md §3).
    stats : PairStats
    """
    scene = load_scene(scene_dir)
    if attributes is not None:
        scene = dataclasses.replace(scene, attributes=attributes.for_clip(scene.clip_id, scene.attributes))
    pairs, stats = make_pairs(scene, min_side=min_side, min_area=min_area, min_visible=min_visible,
                              progress=progress)
    return scene.clip_id, pairs, stats


def _unify(writer: DatasetWriter, attrs_by_file: dict[str, list[str]], methods: set[str]) -> None:
    """Give every file the union of attribute columns (first-seen order), missing ones empty,
    and a ``method`` column when some file (of ``methods``) has one."""
    union = list(dict.fromkeys(a for attrs in attrs_by_file.values() for a in attrs))
    method = [METHOD_COLUMN] if methods else []
    for rel, attrs in attrs_by_file.items():
        if attrs == union and (rel in methods or not methods):
            continue
        path = writer.tmp / rel
        df = pd.read_parquet(path)
        for a in union + method:
            if a not in df.columns:
                df[a] = None

        df = df[[c for c in PAIRS_OUTPUT_COLUMNS if c in df.columns] + method + union + ["scene_root"]]
        t = pa.Table.from_pandas(df, preserve_index=False)
        for a in union + method:
            t = t.set_column(t.column_names.index(a), a, t.column(a).cast(pa.string()))
        pq.write_table(t, path)


def fleet_pairs(scene_dirs, out, *, min_side: float = 30, min_area: float = 0, min_visible: float = MIN_VISIBLE,
                attributes=None, keep_going: bool = False, progress: bool = True) -> FleetResult:
    """Pairs of every scene in ``scene_dirs`` into the dataset folder ``out`` (module docstring).

    ``attributes``: a :class:`nvrq.clip_attributes.ClipAttributes` or ``None``.

    Parameters
    ----------
    scene_dirs : iterable of Path
        Scene folders (:func:`find_scenes`).
    out : str or Path
        The dataset folder, written atomically.
    min_side : float, pixels, optional
        Smallest box side kept.
    min_area : float, pixels, optional
        Smallest box area kept.
    min_visible : float, 0..1, optional
        Smallest visible fraction kept, in both views.
    attributes : ClipAttributes, optional
        Clip attributes that override the scenes'.
    keep_going : bool, optional
        Skip a clip that fails validation (listed in ``failed.csv``) instead of stopping.
    progress : bool, optional
        Show a progress bar.

    Returns
    -------
    FleetResult

    Raises
    ------
    InputError
        A clip fails (without ``keep_going``), a clip id repeats, or no clip passes.
    """

    res, seen, attrs_by_file, methods = FleetResult(), {}, {}, set()
    with DatasetWriter(out) as writer:
        for d in tqdm(scene_dirs, desc="pairs", unit="clip", disable=not progress):
            try:
                clip, pairs, stats = clip_pairs(d, attributes=attributes, min_side=min_side,
                                                 min_area=min_area, min_visible=min_visible)
                if clip in seen:
                    raise InputError(d / "scene.json", "clip_id", "a clip id unique in the fleet",
                                     f"{clip!r}, also in {seen[clip]}")
            except InputError as err:
                if not keep_going:
                    raise
                res.failed.append((_clip_name(d), str(err)))
                continue
            seen[clip] = d
            attrs = [c for c in pairs.columns if c not in (*PAIRS_OUTPUT_COLUMNS, METHOD_COLUMN, "scene_root")]
            writer.string_columns = {*attrs, METHOD_COLUMN}
            writer.write(clip, pairs)
            attrs_by_file[writer.files[-1]] = attrs
            if METHOD_COLUMN in pairs.columns:
                methods.add(writer.files[-1])
            res.clips.append(clip)
            _add_stats(res.stats, stats)
        if not res.clips:
            raise InputError(out, None, "at least one clip that passes validation",
                             f"{len(res.failed)} failed: {res.failed[0][1] if res.failed else 'none given'}")
        _unify(writer, attrs_by_file, methods)
        if res.failed:
            writer.add_file("failed.csv", pd.DataFrame(res.failed, columns=["clip", "reason"]).to_csv(index=False))
    return res
