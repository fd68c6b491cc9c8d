"""The good/bad study (docs/FORMATS.md §5): is the render good enough, next to its GT crop?

An item shows the GT crop (Reference) and one render of one pair; the rater votes good (1)
or bad (0). :class:`BinaryDesign` is the default design of ``annotate build``
(:class:`annotate.design.Design`):

- choose: tracks spread over strata, frames along each track, every chosen view (tracks
  seen at only some views fill in when too few hold all of them;
  :func:`annotate.design.select_test_pairs`) give the test items; training items come from
  other pairs (:func:`annotate.design.pick_training`); hidden gold items alternate
  ``gold-good:<pair_id>`` (the GT crop against a copy of the GT image, must be rated good)
  and ``gold-bad:<pair_id>`` (against a severely broken copy,
  :func:`annotate.crops.broken_render`, must be rated bad), a pool of
  :data:`annotate.design.GOLD_POOL` times the ``2 x n_gold`` each rater is shown (drawn per
  rater: :func:`annotate.assign.draw_gold`); repeats repeat test items (key
  ``repeat:<pair_id>``, item id the test item's);
- cut: the GT and render crops of every item on one square (:func:`annotate.crops.pad_pair`),
  written by :class:`annotate.crops.CropWriter` (dithered, no two alike; a gold copy and a
  repeat cut with their boxes moved by :func:`annotate.crops.draw_shift`, a gold copy's file
  size matched to a real render's).

Items of a multi-method pairs table carry the ``method`` of their render.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from annotate import crops as _crops
from annotate.design import GOLD_POOL, Choice, StudyOptions, attribute_columns, choose_tests
from annotate.store import BINARY_VOTES
from data_schema.methods import method_columns
from data_schema.perturbation import view_columns, with_perturbation_columns
from data_schema.tables import GT_BOX_COLUMNS, PAIR_META_COLUMNS, RENDER_BOX_COLUMNS
from data_schema.vocab import ItemKind, StudyDesign
from nvrq.crops import cut_box

__all__ = ["BinaryDesign"]


class BinaryDesign:
    """The good/bad design (module docstring). Each row of its :class:`~annotate.design.Choice`
    is a dict: ``ref`` (the pairs record), ``kind``, ``key``, ``item_id`` and ``expected``
    (1 gold-good, 0 gold-bad, None otherwise)."""

    name = StudyDesign.BINARY
    votes = BINARY_VOTES
    crops_per_item = 2

    def choose_items(self, pairs: pd.DataFrame, rng: np.random.Generator, opts: StudyOptions, *,
                     where: str) -> Choice:
        """The items of a good/bad study (:meth:`annotate.design.Design.choose_items`; the
        module docstring): ``choice.pairs`` gains the 6-DoF columns when the pairs have views,
        ``choice.method_columns`` is ``['method']`` for multi-method pairs."""
        view_cols = view_columns(pairs)  # [] for lateral-only pairs
        if view_cols:
            pairs = with_perturbation_columns(pairs)
        chosen_offsets, tests, record, training = choose_tests(pairs, rng, opts, has_views=bool(view_cols))
        gold_src = tests.iloc[sorted(rng.choice(len(tests), size=min(GOLD_POOL * 2 * opts.n_gold, len(tests)),
                                                replace=False).tolist())]
        rep_src = tests.iloc[sorted(rng.choice(len(tests), size=min(opts.n_repeats, len(tests)),
                                               replace=False).tolist())]

        def item(r: dict, kind: str, key: str, item_id: str, expected=None) -> dict:
            return {"ref": r, "kind": kind, "key": key, "item_id": item_id, "expected": expected}

        rows = [item(r, ItemKind.TRAINING, "training:" + r["pair_id"], r["pair_id"])
                for r in training.to_dict("records")]
        rows += [item(r, ItemKind.TEST, r["pair_id"], r["pair_id"]) for r in tests.to_dict("records")]
        for i, r in enumerate(gold_src.to_dict("records")):
            tag = "gold-good" if i % 2 == 0 else "gold-bad"
            rows.append(item(r, ItemKind.GOLD, f"{tag}:{r['pair_id']}", f"{tag}:{r['pair_id']}",
                             int(tag == "gold-good")))
        rows += [item(r, ItemKind.REPEAT, "repeat:" + r["pair_id"], r["pair_id"])
                 for r in rep_src.to_dict("records")]
        # items carry the method of their render ([] for single-method pairs)
        return Choice(pairs=pairs, rows=rows, offsets=chosen_offsets, tracks=record,
                      view_columns=view_cols, method_columns=method_columns(pairs))

    def needed_images(self, rows) -> Iterator[tuple[object, str]]:
        """``(pairs record, column)`` of every image the items show: the GT image, and the
        render unless the item is gold (its second crop is made from the GT crop)."""
        for r in rows:
            yield r["ref"], "gt_path"
            if r["kind"] != ItemKind.GOLD:
                yield r["ref"], "render_path"

    def cut_crops(self, choice: Choice, folder: Path, *, ids: list[str], rng: np.random.Generator,
                  image, opts: StudyOptions, where: str, progress: bool) -> pd.DataFrame:
        """The GT crop and the render (gold: a copy of the GT image, or its broken copy drawn
        from ``rng``; module docstring) of every item on one square (:meth:`annotate.design.Design.cut_crops`); the
        items table has ``ref_file, ren_file`` and the pairs row's metadata, view, method and
        attribute columns."""
        fmt, size = opts.image_format, int(opts.size)
        golds = [row["expected"] for row in choice.rows if row["kind"] == ItemKind.GOLD]
        writer = _crops.CropWriter(folder / "crops", fmt=fmt, rng=rng,
                                   groups={"good": golds.count(1), "bad": golds.count(0)})
        attrs = attribute_columns(choice.pairs.drop(columns=["_root", "_row"]))
        items = []
        for k, row in enumerate(tqdm(choice.rows, desc="cutting crops", unit="item", disable=not progress)):
            r, kind, expected = row["ref"], row["kind"], row["expected"]
            line = int(r["_row"])
            ref_file, ren_file = f"{ids[2 * k]}.{fmt}", f"{ids[2 * k + 1]}.{fmt}"
            gt_box = [r[c] for c in GT_BOX_COLUMNS]
            shift = _crops.draw_shift(rng, gt_box) if kind in (ItemKind.GOLD, ItemKind.REPEAT) else (0, 0)
            gt_img = image(r, "gt_path")
            gt = cut_box(gt_img, _crops.shift_box(gt_box, shift if kind == ItemKind.REPEAT else (0, 0), gt_img.shape),
                         where=where, field=f"line {line}: gt box")
            if kind == ItemKind.GOLD:  # the GT image cut with the box moved: a good copy, or broken
                ren = cut_box(gt_img, _crops.shift_box(gt_box, shift, gt_img.shape), where=where,
                              field=f"line {line}: gt box")
                a, _ = _crops.pad_pair(gt, ren, size=size)
                seed = None if expected == 1 else int(rng.integers(2**63))
                b, q = writer.gold((gt, ren), 1, writer.write(ref_file, a), size=size, broken_seed=seed)
                writer.write(ren_file, b, quality=q)
            else:
                ren_img = image(r, "render_path")
                ren = cut_box(ren_img, _crops.shift_box([r[c] for c in RENDER_BOX_COLUMNS], shift,
                                                        ren_img.shape),
                              where=where, field=f"line {line}: render box")
                a, b = _crops.pad_pair(gt, ren, size=size)
                ref_bytes, ren_bytes = writer.write(ref_file, a), writer.write(ren_file, b)
                if kind != ItemKind.REPEAT:
                    writer.note_real(ref_bytes, ren_bytes)
            meta = {c: r[c] for c in (*PAIR_META_COLUMNS, *choice.view_columns, *choice.method_columns, *attrs)}
            items.append({"key": row["key"], "item_id": row["item_id"], "kind": kind, "pair_id": r["pair_id"],
                          "ref_file": ref_file, "ren_file": ren_file,
                          "crop_side": max(*gt.shape[:2], *ren.shape[:2]),
                          "expected": np.nan if expected is None else expected, **meta})
        return pd.DataFrame(items)

    def manifest_extras(self, choice: Choice) -> dict:
        """Nothing: a study without ``design`` in its manifest is a good/bad one."""
        return {}
