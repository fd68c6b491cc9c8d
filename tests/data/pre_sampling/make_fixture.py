"""Make tests/data/pre_sampling: two study folders built by the code before ``--sampling``.

Run once with that code on the path (the parent of commit f47f3a0, issue 37)::

    git archive f47f3a0~1 | tar -x -C /tmp/base
    PYTHONPATH=/tmp/base python tests/data/pre_sampling/make_fixture.py

For each design (``binary``, ``pairwise``) it builds a tiny study from tests/annotate/toy.py,
plays two raters on a copy of it (:func:`play`: every item the old code handed out, and a vote
that is a function of the item key) and writes what the old code did: ``sequence.json`` (the
items in order, with the votes) and ``export.csv`` (``annotate export``, ``voted_at`` dropped).
The study folders are kept without their vote store.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import shutil
import sys
import tempfile
from pathlib import Path

import pandas as pd

HERE = Path(__file__).resolve().parent
RATERS = ("ann", "bob")


def vote_for(key: str, allowed) -> int:
    """A fixed vote per item key (both runs press the same)."""
    allowed = sorted(allowed)
    return allowed[hashlib.sha256(key.encode()).digest()[0] % len(allowed)]


def play(study) -> list[list]:
    """Every rater in turn takes items until done, voting :func:`vote_for`."""
    seq = []
    for rater in RATERS:
        while (key := study.next_item(rater)) is not None:
            vote = vote_for(key, study.store.votes_allowed)
            study.store.record_shown_vote(rater, key, vote, response_ms=700, session="s")
            seq.append([rater, key, vote])
    return seq


def main() -> None:
    from annotate.cli import main as annotate
    from annotate.study import build_study, load_study

    spec = importlib.util.spec_from_file_location("toy", HERE.parents[1] / "annotate" / "toy.py")
    toy = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(toy)
    tmp = Path(tempfile.mkdtemp())
    for design, methods in (("binary", None), ("pairwise", {"alpha": 0.5, "beta": 1.5})):
        scene, pairs = toy.make_toy(tmp / design, **({"methods": methods} if methods else {}))
        out = HERE / design
        shutil.rmtree(out, ignore_errors=True)
        build_study(out, pairs, scene=str(scene), tracks=1, frames_per_track=2, offsets="-1,1",
                    n_training=1, n_gold=1, n_repeats=1, votes_per_item=2, size=32,
                    image_format="png", design=design, progress=False)
        work = tmp / f"{design}-play"
        shutil.copytree(out, work)
        seq = play(load_study(work))
        (out / "sequence.json").write_text(json.dumps(seq, indent=0))
        if annotate(["export", str(work), "--out", str(tmp / "e.csv")]) != 0:
            sys.exit(1)
        pd.read_csv(tmp / "e.csv").drop(columns=["voted_at"]).to_csv(out / "export.csv", index=False)


if __name__ == "__main__":
    main()
