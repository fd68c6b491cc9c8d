"""The pairwise study (docs/FORMATS.md §12): which render of two methods is closer to the GT?

Layer: annotate (rating study).

An *object view* is one object of one frame in one view: the columns
:data:`data_schema.tables.OBJECT_COLUMNS` and the view; its id is the single-method
``pair_id`` of that view (§3, §9: :func:`data_schema.tables.pair_ids` without methods). A
pairs table with a ``method`` column holds one row per object view and method (same GT crop,
the method's render). A pairwise item shows the GT crop (Reference) and the renders of two
methods A and B of one object view; A is the earlier of the two in the study's method list.

- :func:`study_methods`: the methods of a study (``--methods`` or every method of the table).
- :class:`PairwiseDesign` (:class:`annotate.design.Design`), the design of ``annotate build
  --design pairwise``: object views holding every chosen method are chosen as the binary
  design chooses pairs (tracks spread over strata, frames along each track, every view;
  :func:`annotate.design.select_test_pairs`) and each gives one test item per pair of
  methods. Training items come from other object views (pairs of methods in turn); hidden
  gold items show a copy of the GT image as A (``method_a = gt``; the right answer is ``a``)
  against one method's render of an object view away from the real camera (``view !=
  none`` when there is one); repeats repeat test items (shown with the sides swapped:
  :func:`annotate.assign.pairwise_sides`). Its crops: the three display crops of every item
  on one square (one scale).
- :func:`choice`: the rater's answer in A/B terms from the side pressed.

Item keys and ids: a test item's id is ``OBJECT_VIEW_ID|A|B``; keys ``training:ID``,
``gold:OBJECT_VIEW_ID|gt|M`` (key = id) and ``repeat:ID`` (id: the test item's), as in the
binary study. The votes store the side pressed: 1 left, 2 right, 0 can't tell (the keys).

>>> choice([1, 2, 0, 1], ["left", "left", "right", "right"]).tolist()
['a', 'b', 'tie', 'b']
"""

from __future__ import annotations

from collections.abc import Iterator
from itertools import combinations
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from annotate import crops as _crops
from annotate.design import GOLD_POOL, Choice, StudyOptions, attribute_columns, choose_tests
from data_schema.errors import InputError
from data_schema.methods import GT_METHOD, METHOD_COLUMN, table_methods
from data_schema.perturbation import labels, perturbation_array, view_columns
from data_schema.perturbation import with_perturbation_columns as _with_views
from data_schema.tables import GT_BOX_COLUMNS, PAIR_META_COLUMNS, RENDER_BOX_COLUMNS, pair_ids
from data_schema.vocab import ItemKind, Side, StudyDesign
from nvrq.crops import cut_box

__all__ = ["METHOD_COLUMN", "GT_METHOD", "VOTE_CODES", "study_methods", "PairwiseDesign", "choice"]

#: stored vote codes of a pairwise study: the key pressed
VOTE_CODES = {1: "left", 2: "right", 0: "can't tell"}


def study_methods(pairs: pd.DataFrame, methods: str | None, *, where: str) -> list[str]:
    """The methods a pairwise study compares, in order: ``methods`` (a comma list of methods
    of ``pairs``), or with None every method ``pairs`` holds
    (:func:`data_schema.methods.table_methods`, sorted). ``pairs`` is the checked pairs table
    (its reader has checked the names: never the reserved :data:`GT_METHOD`), named ``where``
    in errors.

    Raises :class:`InputError` for no ``method`` column, an empty method, a name not in the
    table or a repeated one (naming the parameter ``methods``), or fewer than two.

    Parameters
    ----------
    pairs : pandas.DataFrame
        The checked pairs table.
    methods : str or None
        Comma list of methods, or ``None`` for all.
    where : str
        The pairs table, named in errors.

    Returns
    -------
    list of str
    """
    have = table_methods(pairs, where=where,
                         expected="a method column (one render per method) for `design` pairwise")
    col = pairs[METHOD_COLUMN]
    bad = col.isna() | (col.astype(str).str.strip() == "")
    if bad.any():
        raise InputError(where, f"line {int(np.argmax(bad.to_numpy())) + 2}: column 'method'",
                         "a method name", "an empty value")
    if methods is None:
        chosen = have
    else:
        chosen = [m.strip() for m in str(methods).split(",") if m.strip()]
        unknown = [m for m in chosen if m not in have]
        if unknown:
            raise InputError(param="methods", expected=f"methods of {where}'s method column "
                             f"({', '.join(have)})", got=unknown[0])
        if len(set(chosen)) != len(chosen):
            raise InputError(param="methods", expected="each method once", got=methods)
    if len(chosen) < 2:
        expected, got = "at least 2 methods to compare", ", ".join(chosen) or "none"
        if methods is not None:
            raise InputError(param="methods", expected=expected, got=got)
        raise InputError(where, "column 'method'", expected, got)
    return chosen


def _complete_views(pairs: pd.DataFrame, methods: list[str], *, where: str) -> pd.DataFrame:
    """Rows of the chosen methods at object views holding every one of them (``_view``,
    ``_object`` columns added)."""
    df = pairs[pairs[METHOD_COLUMN].astype(str).isin(methods)]
    df = df.assign(**{METHOD_COLUMN: df[METHOD_COLUMN].astype(str),
                      "_view": labels(perturbation_array(df)), "_object": pair_ids(df)})
    dup = df.duplicated(["_object", METHOD_COLUMN])
    if dup.any():
        row = df[dup].iloc[0]
        raise InputError(where, f"line {int(row['_row'])}",
                         "one render per object, view and method", f"{row['_object']} "
                         f"{row[METHOD_COLUMN]} twice")
    n = df.groupby("_object")[METHOD_COLUMN].transform("nunique")
    return df[n == len(methods)]


class PairwiseDesign:
    """The pairwise design (module docstring). Each row of its :class:`~annotate.design.Choice`
    is a dict: ``kind``, ``key``, ``item_id``, ``method_a``, ``method_b`` and the pairs records
    ``ref`` (the GT crop's), ``a`` (None: the GT crop itself) and ``b``."""

    name = StudyDesign.PAIRWISE
    votes = VOTE_CODES
    crops_per_item = 3

    def choose_items(self, pairs: pd.DataFrame, rng: np.random.Generator, opts: StudyOptions, *,
                     where: str) -> Choice:
        """The items of a pairwise study (:meth:`annotate.design.Design.choose_items`; the
        module docstring): ``choice.pairs`` is ``pairs``, ``choice.methods`` the compared ones
        (:func:`study_methods`). Errors also for two renders of one object view and method,
        or no object view rendered by every method."""
        methods = study_methods(pairs, opts.methods, where=where)
        full = _complete_views(pairs, methods, where=where)
        if full.empty:
            raise InputError(where, "column 'method'", f"object views rendered by every method of "
                             f"{methods}", "none")
        view_cols = view_columns(pairs)
        if view_cols:
            full = _with_views(full)
        by_method = {m: g.set_index("_object") for m, g in full.groupby(METHOD_COLUMN)}
        base = by_method[methods[0]].reset_index()  # one row per object view
        chosen_offsets, tests, record, training = choose_tests(base, rng, opts, has_views=bool(view_cols))
        duos = list(combinations(methods, 2))

        def item(obj: str, kind: str, a: str, b: str, prefix: str = "") -> dict:
            item_id = f"{obj}|{a}|{b}"
            return {"kind": kind, "key": prefix + item_id, "item_id": item_id, "method_a": a,
                    "method_b": b, "ref": by_method[methods[0]].loc[obj],
                    "a": None if a == GT_METHOD else by_method[a].loc[obj], "b": by_method[b].loc[obj]}

        rows = [item(obj, ItemKind.TRAINING, *duos[i % len(duos)], prefix="training:")
                for i, obj in enumerate(training["_object"])]
        test_rows = [item(obj, ItemKind.TEST, a, b) for obj in tests["_object"] for a, b in duos]
        rows += test_rows
        away = tests[tests["_view"] != "none"] if (tests["_view"] != "none").any() else tests
        n_gold = min(GOLD_POOL * 2 * opts.n_gold, len(away))  # the pool
        for obj in away["_object"].iloc[sorted(rng.choice(len(away), size=n_gold, replace=False))]:
            m = methods[int(rng.integers(len(methods)))]
            gold = item(obj, ItemKind.GOLD, GT_METHOD, m, prefix="gold:")
            rows.append({**gold, "item_id": gold["key"]})
        n_rep = min(opts.n_repeats, len(test_rows))
        for i in sorted(rng.choice(len(test_rows), size=n_rep, replace=False).tolist()):
            r = test_rows[i]
            rows.append({**r, "kind": ItemKind.REPEAT, "key": "repeat:" + r["item_id"]})
        return Choice(pairs=pairs, rows=rows, offsets=chosen_offsets, tracks=record,
                      view_columns=view_cols, methods=methods)

    def needed_images(self, rows) -> Iterator[tuple[object, str]]:
        """``(pairs record, column)`` of every image the items ``rows`` show: the GT crop's
        image and the renders of A (unless it is the GT crop) and B."""
        for r in rows:
            yield r["ref"], "gt_path"
            if r["a"] is not None:
                yield r["a"], "render_path"
            yield r["b"], "render_path"

    def cut_crops(self, choice: Choice, folder: Path, *, ids: list[str], rng: np.random.Generator,
                  image, opts: StudyOptions, where: str, progress: bool) -> pd.DataFrame:
        """The GT, A and B crops of every item on one square, the largest side of the three
        (:meth:`annotate.design.Design.cut_crops`), written by :class:`annotate.crops.CropWriter`
        with ``rng`` (a gold item's A: the GT image cut with its box moved by
        :func:`annotate.crops.draw_shift`, its file size matched to a real render's; a
        repeat: every box moved so); the items table has ``ref_file, a_file, b_file``, the
        methods and their pair ids."""
        fmt, size = opts.image_format, int(opts.size)
        writer = _crops.CropWriter(folder / "crops", fmt=fmt, rng=rng,
                                   groups={"good": sum(r["kind"] == ItemKind.GOLD for r in choice.rows)})
        attrs = attribute_columns(choice.pairs.drop(columns=["_root", "_row"]))
        items = []
        for k, r in enumerate(tqdm(choice.rows, desc="cutting crops", unit="item", disable=not progress)):
            ref, kind = r["ref"], r["kind"]
            gt_img, gt_box = image(ref, "gt_path"), [ref[c] for c in GT_BOX_COLUMNS]
            shift = _crops.draw_shift(rng, gt_box) if kind in (ItemKind.GOLD, ItemKind.REPEAT) else (0, 0)
            moved = shift if kind == ItemKind.REPEAT else (0, 0)
            gt = _cut(gt_img, gt_box, moved, ref, "gt", where)
            # A: a render, or (gold) the GT image cut with the box moved
            ren = [_cut(gt_img, gt_box, shift, ref, "gt", where) if rec is None else _cut(
                image(rec, "render_path"), [rec[c] for c in RENDER_BOX_COLUMNS], moved, rec,
                "render", where) for rec in (r["a"], r["b"])]
            crops = (gt, *ren)
            side = max(max(c.shape[:2]) for c in crops)
            names = {col: f"{ids[3 * k + j]}.{fmt}" for j, col in enumerate(("ref_file", "a_file", "b_file"))}
            shown = _crops.pad_group(crops, size=size)
            written = {}
            for col, out in zip(names, shown, strict=True):
                q = None
                if col == "a_file" and r["a"] is None:  # gold: A's file size as a real render's
                    out, q = writer.gold(crops, 1, written["ref_file"], size=size)
                written[col] = writer.write(names[col], out, quality=q)
            if kind in (ItemKind.TEST, ItemKind.TRAINING):
                writer.note_real(written["ref_file"], written["a_file"])
                writer.note_real(written["ref_file"], written["b_file"])
            meta = {c: ref[c] for c in (*PAIR_META_COLUMNS, *choice.view_columns, *attrs)}
            items.append({"key": r["key"], "item_id": r["item_id"], "kind": r["kind"],
                          "pair_id": r["ref"].name, "method_a": r["method_a"],
                          "method_b": r["method_b"],
                          "pair_id_a": "" if r["a"] is None else r["a"]["pair_id"],
                          "pair_id_b": r["b"]["pair_id"], **names, "crop_side": side,
                          "expected": "a" if r["kind"] == ItemKind.GOLD else "", **meta})
        return pd.DataFrame(items)

    def manifest_extras(self, choice: Choice) -> dict:
        """``design`` and the compared ``methods``."""
        return {"design": StudyDesign.PAIRWISE, "methods": list(choice.methods)}


def _cut(img: np.ndarray, box, shift: tuple[int, int], rec, what: str, where: str) -> np.ndarray:
    """The crop of ``img`` at ``box`` moved by ``shift`` (:func:`annotate.crops.shift_box`);
    errors name the pairs line of ``rec`` and the ``what`` box."""
    return cut_box(img, _crops.shift_box(box, shift, img.shape), where=where,
                   field=f"line {int(rec['_row'])}: {what} box")


def choice(vote, side_a) -> np.ndarray:
    """The answer in A/B terms: ``(N,)`` of ``'a'``, ``'b'``, ``'tie'`` from the stored votes
    (1 left, 2 right, 0 can't tell) and the side A was shown on (``'left'``/``'right'``).

    Parameters
    ----------
    vote : (N,) int
        Stored votes: 1 left, 2 right, 0 can't tell.
    side_a : (N,) str
        The side A was shown on, ``{'left', 'right'}``.

    Returns
    -------
    (N,) object array of str
        ``{'a', 'b', 'tie'}``.
    """
    v = np.asarray(vote, dtype=np.int64)
    left_a = np.asarray(side_a, dtype=object) == Side.LEFT
    return np.where(v == 0, "tie", np.where((v == 1) == left_a, "a", "b")).astype(object)
