"""Rate yourself after the demo: a small binary study of items the simulated raters rated, and
your agreement with them (annotate layer; ``annotate rate-yourself DEMO``).

:func:`build_own_study` picks about ``n`` test items of the demo's study that simulated raters
voted on (whole frames of a track, every view of the object, spread over tracks, seeded), and
builds ``DEMO/yourself``: those items only, no training,
gold or repeated items, one vote each, open access on this machine (the rater types a name).
:func:`own_agreement` compares your votes with the simulated raters' on the same items: with
their majority (an item whose simulated votes tie has none), and with each simulated rater,
beside how often a simulated rater agrees with the majority of the others (the same number for
them, so that yours can be read against it).

>>> import pandas as pd
>>> sim = pd.DataFrame({"rater": ["s1", "s2", "s3"] * 2, "item": ["a"] * 3 + ["b"] * 3,
...                     "vote": [1, 1, 0, 0, 0, 0]})
>>> mine = pd.DataFrame({"item": ["a", "b"], "vote": [1, 1]})
>>> a = own_agreement(mine, sim)
>>> a["n_items"], a["n_majority"], a["with_majority"]
(2, 2, 0.5)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from data_schema.errors import InputError
from data_schema.vocab import ItemKind, StudyDesign

__all__ = ["OWN_STUDY", "OWN_ITEMS", "build_own_study", "own_agreement", "agreement_lines"]

#: the small study's folder inside the demo's folder
OWN_STUDY = "yourself"
#: how many items the small study has by default
OWN_ITEMS = 20


def build_own_study(demo: str | Path, *, n: int = OWN_ITEMS, seed: int = 0) -> Path:
    """Build ``DEMO/yourself``: ``n`` of the demo study's test items that simulated raters voted on.

    Parameters
    ----------
    demo : str or pathlib.Path
        The folder ``nvrq demo`` wrote (``study/`` with simulated votes, ``pairs.csv``).
    n : int
        Items to rate, about: the whole frames whose views add up nearest to ``n`` (fewer when
        the demo has fewer).
    seed : int
        Seed of the choice.

    Returns
    -------
    pathlib.Path
        The new study's folder.

    Raises
    ------
    InputError
        ``demo`` is no finished binary demo, or ``DEMO/yourself`` exists with files in it.
    """
    from annotate.study import build_study, load_study
    from data_schema.tables import OBJECT_COLUMNS, TableKind, read_table

    demo = Path(demo)
    study_dir, pairs_path = demo / "study", demo / "pairs.csv"
    if not (study_dir / "manifest.json").is_file() or not pairs_path.is_file():
        raise InputError(demo, None, "the folder of a finished nvrq demo (study/ and pairs.csv)",
                         "no such study or pairs table")
    study = load_study(study_dir)
    design = study.manifest.design
    if design != StudyDesign.BINARY:
        raise InputError(study_dir, None, "the study of nvrq demo (good/bad votes); the methods demo's "
                         "pairwise study is rated with annotate serve", f"a {design} study")
    votes = study.store.votes()
    items = study.items[study.items["kind"] == ItemKind.TEST]
    rated = items[items["key"].isin(votes.loc[votes["rater"].str.startswith("sim-"), "item"])]
    if rated.empty:
        raise InputError(study_dir, None, "test items with simulated votes (annotate simulate)", "none")
    # whole frames of a track (every view of one object, as the study shows them), spread over
    # tracks: a random order of the frames within each track, then the tracks taken in turn
    frame = list(OBJECT_COLUMNS)
    groups = rated.groupby(frame).size().rename("n").reset_index()
    rng = np.random.default_rng(seed)
    groups = groups.assign(_r=rng.random(len(groups))).sort_values(["track_id", "_r"])
    groups = groups.assign(_k=groups.groupby("track_id").cumcount()).sort_values(["_k", "_r"], kind="stable")
    total = groups["n"].cumsum().to_numpy()
    keep = int(np.argmin(np.abs(total - int(n)))) + 1  # the whole frames nearest n items in all
    chosen = groups.head(keep)
    pairs = read_table(pairs_path, kind=TableKind.PAIRS, dtype={"pair_id": str, "track_id": str,
                                                               "camera": str, "clip_id": str})
    key = pd.MultiIndex.from_frame(pairs[frame])
    mine = pairs[key.isin(pd.MultiIndex.from_frame(chosen[frame].astype(pairs[frame].dtypes.to_dict())))]
    out = demo / OWN_STUDY
    own_pairs = demo / "yourself-pairs.csv"
    mine.to_csv(own_pairs, index=False)
    scene = demo / "scene" if (demo / "scene").is_dir() else None
    build_study(out, own_pairs, tracks=len(chosen), frames_per_track=len(chosen), offsets="all",
                votes_per_item=1, n_training=0, n_gold=0, n_repeats=0, items_per_rater=None,
                seed=seed, access="open", scene=None if scene is None else str(scene), progress=False)
    return out


def own_agreement(mine: pd.DataFrame, simulated: pd.DataFrame) -> dict:
    """Your agreement with the simulated raters on the items you rated.

    Parameters
    ----------
    mine : pandas.DataFrame
        Your votes: ``item``, ``vote`` (1 good, 0 bad), one row per item.
    simulated : pandas.DataFrame
        The simulated raters' votes: ``rater``, ``item``, ``vote``.

    Returns
    -------
    dict
        ``n_items`` (your items with simulated votes), ``n_majority`` (of them, those with a
        simulated majority), ``with_majority`` (your share of agreement with it, NaN without
        any), ``with_each`` (mean over simulated raters of your share of agreement with each,
        on the items both rated), ``sim_with_others`` (mean over simulated raters of their
        agreement with the majority of the other simulated raters on your items, NaN when none
        can be told).
    """
    sim = simulated[simulated["item"].isin(mine["item"])]
    own = mine.set_index("item")["vote"].astype(int)
    counts = sim.groupby("item")["vote"].agg(["sum", "count"])
    major = pd.Series(np.where(2 * counts["sum"] > counts["count"], 1,
                               np.where(2 * counts["sum"] < counts["count"], 0, -1)), index=counts.index)
    decided = major[major >= 0]
    with_major = float((own.loc[decided.index] == decided).mean()) if len(decided) else float("nan")
    each = [float((own.loc[g["item"]].to_numpy() == g["vote"].to_numpy()).mean())
            for _, g in sim.groupby("rater")]
    loo = []
    for rater, g in sim.groupby("rater"):
        rest = sim[sim["rater"] != rater].groupby("item")["vote"].agg(["sum", "count"])
        rest = rest[2 * rest["sum"] != rest["count"]]
        g = g[g["item"].isin(rest.index)]
        if len(g):
            m = (2 * rest.loc[g["item"], "sum"] > rest.loc[g["item"], "count"]).astype(int)
            loo.append(float((g["vote"].to_numpy() == m.to_numpy()).mean()))
    return {"n_items": int(counts.shape[0]), "n_majority": int(len(decided)), "with_majority": with_major,
            "with_each": float(np.mean(each)) if each else float("nan"),
            "sim_with_others": float(np.mean(loo)) if loo else float("nan")}


def agreement_lines(result: dict, *, n_raters: int) -> list[str]:
    """What ``annotate rate-yourself`` prints of :func:`own_agreement`'s ``result``.

    Parameters
    ----------
    result : dict
        :func:`own_agreement`'s result.
    n_raters : int
        The simulated raters.

    Returns
    -------
    list of str
        Full sentences.
    """
    from data_schema.text import plural

    r = result
    if not r["n_items"]:
        return ["None of your votes is on an item the simulated raters rated."]
    lines = [f"You rated {plural(r['n_items'], 'item')} that {plural(n_raters, 'simulated rater')} rated too."]
    if r["n_majority"]:
        agree = int(round(r["with_majority"] * r["n_majority"]))
        lines.append(f"Your vote agrees with their majority on {agree} of {plural(r['n_majority'], 'item')} "
                     f"({100 * r['with_majority']:.0f}%).")
    lines.append(f"You agree with each simulated rater on {100 * r['with_each']:.0f}% of these items on average.")
    if np.isfinite(r["sim_with_others"]):
        lines.append(f"For comparison, a simulated rater agrees with the majority of the others on "
                     f"{100 * r['sim_with_others']:.0f}% of them.")
    return lines
