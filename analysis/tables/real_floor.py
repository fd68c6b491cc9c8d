"""The viewpoint floor on real photographs (analysis layer; ``analyze --pairs PAIRS
--metrics-table METRICS --real-floor``, docs/FORMATS.md §16).

A ``real`` pair (``nvrq import stereo``) compares the left image's crop with the right image's
crop of the same object: nothing is reconstructed, so what a metric gives there is its response
to the change of view alone, on real images. This module sets it beside:

- **misalignment alone**: the same GT crop against the GT box moved ``k`` pixels sideways inside
  the GT image (:data:`SHIFTS_PX` = 5, 10, 20), scored here with :func:`nvrq.score_crops` for
  every metric column of the tables that ``nvrq score`` computes (an encoder column
  ``FAMILY:ENCODER`` with its encoder). Each pair's value is the mean over the moves left and
  right that keep the box inside the image (a pair with neither is left out);
- **renders at the matched change of viewing angle**: every other method of the pairs (the
  ``perfect`` synthetic renders of ``nvrq demo`` among them) on its pairs whose viewing-angle
  change lies within the range of the ``real`` pairs'. A pair's viewing-angle change is
  ``atan(|du| / fx)`` degrees, ``du`` the move of the box centre between the two views and
  ``fx`` the camera's focal length in pixels (for a lateral move ``B`` at depth ``Z``,
  ``du = fx B / Z``: the angle ``atan(B / Z)`` under which the baseline is seen from the object);
  cameras without a ``focal_length`` (f-theta) give no angle.

:func:`real_floor` returns the long table (floor.csv) and :func:`floor_sentence` the report's
sentence; :func:`context` the report's variables.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from data_schema.errors import InputError
from data_schema.methods import METHOD_COLUMN, REAL_METHOD, method_values

__all__ = ["SHIFTS_PX", "FLOOR_COLUMNS", "FloorResult", "read_floor_pairs", "view_angles", "misaligned_scores",
           "real_floor", "floor_display", "floor_sentence", "context", "write_floor"]

#: the moves of the GT box (pixels) that measure misalignment alone
SHIFTS_PX = (5, 10, 20)
#: floor.csv's columns: one row per (row, metric)
FLOOR_COLUMNS = ["row", "method", "shift_px", "baseline_m", "angle_lo_deg", "angle_hi_deg", "n", "metric",
                 "higher_better", "mean"]
_BOX = ["gt_x0", "gt_y0", "gt_x1", "gt_y1", "r_x0", "r_y0", "r_x1", "r_y1"]
_NEEDED = ["pair_id", "camera", "gt_path", "y_offset_m", "scene_root", *_BOX]


@dataclass
class FloorResult:
    """The floor: ``table`` (:data:`FLOOR_COLUMNS`), the ``metrics`` in order and ``notes``."""

    table: pd.DataFrame
    metrics: list
    notes: list


def _read_any(path) -> pd.DataFrame:
    from data_schema.tables import read_table

    path = Path(path)
    if path.is_dir():
        import pyarrow.parquet as pq

        return pq.read_table(path).to_pandas()
    return read_table(path, dtype={"pair_id": str})


def read_floor_pairs(pairs_path, metrics_paths) -> pd.DataFrame:
    """The pairs (a table or a dataset) with their boxes, paths and method, joined on ``pair_id``
    with the metrics tables.

    Parameters
    ----------
    pairs_path : str or Path
        ``nvrq pairs``'s output.
    metrics_paths : sequence of str or Path
        ``nvrq score``'s outputs.

    Returns
    -------
    pandas.DataFrame
        One row per pair; ``method`` ``''`` where none.
    """
    pairs = _read_any(pairs_path)
    missing = [c for c in _NEEDED if c not in pairs.columns]
    if missing:
        raise InputError(pairs_path, f"column {missing[0]!r}", "a pairs table of nvrq pairs (boxes, paths, "
                         "scene_root) for the floor", "no such column")
    pairs = pairs.assign(**{METHOD_COLUMN: method_values(pairs)})
    for path in metrics_paths:
        m = _read_any(path)
        if "pair_id" not in m.columns:
            raise InputError(path, "column 'pair_id'", "a metrics table", "no such column")
        keep = [c for c in m.columns if c == "pair_id" or c not in pairs.columns]
        pairs = pairs.merge(m[keep], on="pair_id", how="left")
    return pairs


def view_angles(pairs: pd.DataFrame, *, focal: dict | None = None) -> np.ndarray:
    """Each pair's viewing-angle change ``atan(|du| / fx)`` in degrees (module docstring); NaN
    where the camera has no ``focal_length``.

    Parameters
    ----------
    pairs : pandas.DataFrame
        With the box columns, ``camera`` and ``scene_root``.
    focal : dict, optional
        ``(scene_root, camera) -> fx`` known already (the rest is read from ``scene.json``;
        filled in as read).

    Returns
    -------
    (N,) float numpy.ndarray

    >>> p = pd.DataFrame({"gt_x0": [100], "gt_x1": [200], "r_x0": [50], "r_x1": [150], "camera": ["c"],
    ...                   "scene_root": ["/nowhere"]})
    >>> round(float(view_angles(p, focal={("/nowhere", "c"): 1000.0})[0]), 4)  # atan(50 / 1000)
    2.8624
    """
    focal = {} if focal is None else focal
    du = np.abs((pairs["gt_x0"] + pairs["gt_x1"]).to_numpy(float) - (pairs["r_x0"] + pairs["r_x1"]).to_numpy(float)) / 2
    fx = np.array([_focal(str(r), str(c), focal) for r, c in zip(pairs["scene_root"], pairs["camera"], strict=True)])
    return np.degrees(np.arctan(du / fx))


def _focal(root: str, camera: str, cache: dict) -> float:
    if (root, camera) not in cache:
        try:
            model = json.loads((Path(root) / "scene.json").read_text())["cameras"][camera]["model"]
            cache[root, camera] = float(model["focal_length"][0])
        except (OSError, ValueError, KeyError, TypeError, IndexError):
            cache[root, camera] = float("nan")
    return cache[root, camera]


def _metric_groups(columns) -> dict:
    """``{encoder or None: [(column, metric name)]}`` of the columns ``nvrq score`` computes."""
    from nvrq.metrics import column_info, encoder_columns, reference_columns, split_column

    known = [c for c in columns if column_info(c, default=None) is not None]
    encoded = set(encoder_columns(known))
    groups: dict = {}
    for col in reference_columns(known):
        family, member = split_column(col)
        key, name = (member, family) if col in encoded else (None, col)
        groups.setdefault(key, []).append((col, name))
    return groups


def _read_rgb(path: Path) -> np.ndarray:
    import cv2

    img = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if img is None:
        raise InputError(path, None, "a readable GT image", "no such file or undecodable")
    return cv2.cvtColor(img, cv2.COLOR_BGR2RGB)


def misaligned_scores(pairs: pd.DataFrame, columns, *, shift: int) -> pd.DataFrame:
    """Each pair's metrics between its GT crop and the GT box moved ``shift`` pixels left and
    right inside the GT image (the mean of the moves that fit).

    Parameters
    ----------
    pairs : pandas.DataFrame
        The ``real`` pairs (boxes, ``gt_path``, ``scene_root``).
    columns : sequence of str
        Metric columns (``psnr``, ``nvrq_ca:ENCODER``, ...); those ``nvrq score`` cannot compute
        between two crops are left out.
    shift : int
        Pixels.

    Returns
    -------
    pandas.DataFrame
        ``pair_id`` and one column per metric kept; pairs with no move inside are left out.
    """
    from nvrq import score_crops
    from nvrq.crops import cut_box

    images: dict = {}
    gt, moved, owner = [], [], []
    for r in pairs.itertuples(index=False):
        path = Path(r.scene_root) / r.gt_path
        if path not in images:
            images[path] = _read_rgb(path)
        img = images[path]
        box = np.array([r.gt_x0, r.gt_y0, r.gt_x1, r.gt_y1], np.int64)
        crop = cut_box(img, box, where=str(path))
        for s in (-shift, shift):
            b = box + np.array([s, 0, s, 0])
            if b[0] >= 0 and b[2] <= img.shape[1] - 1:
                gt.append(crop)
                moved.append(cut_box(img, b, where=str(path)))
                owner.append(r.pair_id)
    out = pd.DataFrame({"pair_id": owner})
    for encoder, cols in _metric_groups(columns).items():
        if not gt:
            break
        got = score_crops(gt, moved, metrics=[n for _, n in cols], encoder=encoder)
        for col, _ in cols:
            out[col] = got[col].to_numpy()
    return out.groupby("pair_id", sort=False).mean().reset_index() if len(out) else out


def real_floor(pairs: pd.DataFrame, metrics, directions: dict, *, shifts=SHIFTS_PX) -> FloorResult:
    """The floor table (module docstring) of the pairs' ``real`` rows.

    Parameters
    ----------
    pairs : pandas.DataFrame
        :func:`read_floor_pairs`.
    metrics : sequence of str
        The metric columns to report.
    directions : dict
        Metric -> higher is better.
    shifts : sequence of int
        The GT-box moves, pixels.

    Returns
    -------
    FloorResult

    Raises
    ------
    InputError
        The pairs have no ``real`` row.
    """
    method = pairs[METHOD_COLUMN].astype(str)
    real = pairs[method == REAL_METHOD]
    if real.empty:
        raise InputError(param="pairs", expected="pairs of method real (`nvrq import stereo`) for the floor",
                         got="none")
    focal: dict = {}
    angle = view_angles(pairs, focal=focal)
    real_angle = angle[(method == REAL_METHOD).to_numpy()]
    lo, hi = float(np.nanmin(real_angle)), float(np.nanmax(real_angle))
    baseline = float(np.median(np.abs(real["y_offset_m"])))
    metrics = [m for m in metrics if m in pairs.columns]
    rows = []

    def add(row, meth, shift, values: pd.DataFrame, a_lo, a_hi, base):
        for m in metrics:
            v = pd.to_numeric(values[m], errors="coerce") if m in values.columns else pd.Series(dtype=float)
            v = v[np.isfinite(v)]
            rows.append((row, meth, shift, base, a_lo, a_hi, len(v), m, directions.get(m),
                         float(v.mean()) if len(v) else np.nan))

    add(f"real photograph ({baseline:.2f} m)", REAL_METHOD, 0, real, lo, hi, baseline)
    notes = [f"{len(real)} real pairs at {baseline:.3g} m, viewing-angle change {lo:.2f} to {hi:.2f} deg"]
    for k in shifts:
        add(f"GT crop moved {k} px", "", k, misaligned_scores(real, metrics, shift=int(k)), np.nan, np.nan, np.nan)
    matched = (angle >= lo) & (angle <= hi) & (method != REAL_METHOD).to_numpy()
    others = sorted(set(method[(method != REAL_METHOD).to_numpy()]), key=lambda m: (m != "perfect", m))
    for m in others:
        sel = matched & (method == m).to_numpy()
        p = pairs[sel]
        label = "perfect synthetic renders" if m == "perfect" else f"renders {m or '(no method)'}"
        if sel.any():
            add(f"{label} (matched angle)", m, 0, p, lo, hi, float(np.median(np.abs(p["y_offset_m"]))))
        else:
            notes.append(f"{label}: no pair within the real pairs' viewing-angle change ({lo:.2f} to {hi:.2f} deg; "
                         f"theirs {np.nanmin(angle[(method == m).to_numpy()]):.2f} to "
                         f"{np.nanmax(angle[(method == m).to_numpy()]):.2f} deg)")
    return FloorResult(pd.DataFrame(rows, columns=FLOOR_COLUMNS), metrics, notes)


def floor_display(result: FloorResult) -> pd.DataFrame:
    """The report's table: one row per floor row, ``n`` and one column per metric (3 digits).

    Parameters
    ----------
    result : FloorResult

    Returns
    -------
    pandas.DataFrame
    """
    t = result.table
    wide = t.pivot_table(index="row", columns="metric", values="mean", sort=False, dropna=False)
    n = t.groupby("row", sort=False)["n"].max()
    out = pd.DataFrame({"row": wide.index, "n": n.reindex(wide.index).to_numpy()})
    for m in result.metrics:
        out[m] = [f"{v:.3g}" if np.isfinite(v) else "" for v in wide[m].to_numpy()]
    return out.reset_index(drop=True)


def _headline(metrics) -> str | None:
    return next((m for m in metrics if m.startswith("nvrq_ca")), metrics[0] if metrics else None)


def floor_sentence(result: FloorResult) -> str:
    """One sentence: the real photograph's value of the headline metric (NVRQ-CA when scored),
    the misalignment it equals and, when present, the renders' value at the matched angle.

    Parameters
    ----------
    result : FloorResult

    Returns
    -------
    str
    """
    t = result.table
    m = _headline(result.metrics)
    if m is None:
        return "No metric was scored on the real pairs."
    at = t[t["metric"] == m].set_index("row")
    real = at.iloc[0]
    text = f"At {real['baseline_m']:.2f} m, a real photograph scores {m} {real['mean']:.3g}"
    moved = at[at["shift_px"] > 0]
    if len(moved):
        parts = ", ".join(f"{int(r.shift_px)} px {r.mean:.3g}" for r in moved.itertuples())
        text += f" (the GT crop merely moved: {parts})"
    renders = at[(at["shift_px"] == 0) & (at["method"] != REAL_METHOD)]
    if len(renders):
        text += "; your renders at the matched viewing angle score " + ", ".join(
            f"{r.method or '(no method)'} {r.mean:.3g}" for r in renders.itertuples())
    return text + "."


def write_floor(result: FloorResult | None, d: Path) -> None:
    """Write ``d/floor.csv`` (nothing without a result).

    Parameters
    ----------
    result : FloorResult or None
    d : pathlib.Path
        The report folder.
    """
    if result is not None:
        from data_schema.tables import write_table

        write_table(result.table, d / "floor.csv")


def context(result: FloorResult | None, table) -> dict:
    """The report's variables of the "Viewpoint floor" section (empty without a result).

    Parameters
    ----------
    result : FloorResult or None
    table : callable
        Renders a DataFrame for the page.

    Returns
    -------
    dict
        ``floor_sentence``, ``floor_table``, ``floor_notes``.
    """
    if result is None:
        return {"floor_sentence": ""}
    return {"floor_sentence": floor_sentence(result), "floor_table": table(floor_display(result)),
            "floor_notes": [*result.notes, "Every row and metric: floor.csv. Misalignment: the GT box moved "
                            "left and right inside the GT image (mean of the moves that fit); matched angle: "
                            "pairs whose atan(|du| / fx) lies within the real pairs' range."]}
