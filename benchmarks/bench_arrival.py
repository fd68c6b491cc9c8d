"""A crowd arrival at a large study: is the study full? (``annotate.access.crowd_arrival``).

Every arrival of a crowd study asks :meth:`annotate.study.Study.is_full` before it gets an
identity. The old check counted every stored vote per item (``SELECT item, COUNT(*) FROM
votes GROUP BY item``: 499 ms at a million votes, issue 44); the new one reads the per-item
counters the store's triggers keep (one row per item). Both are measured side by side in the
same run on the same store file, at each ``--votes`` size (the votes and their history rows are
written straight into the store, its triggers keeping the counters, as :func:`bench_raters._prefill` does),
for a uniform and an adaptive study; the counts of the two are checked equal first. Target:
an arrival under 20 ms at a million votes.

Run: ``nice -n 10 python benchmarks/bench_arrival.py`` (default sizes 10^4, 10^5, 10^6;
about a minute, most of it writing the votes).
"""

from __future__ import annotations

import argparse
import importlib.util
import sqlite3
import statistics
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd

from annotate.access import crowd_arrival
from annotate.study import build_study, load_study

_spec = importlib.util.spec_from_file_location("bench_raters_for_arrival",
                                               Path(__file__).with_name("bench_raters.py"))
bench_raters = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = bench_raters
_spec.loader.exec_module(bench_raters)

TARGET_MS = 20.0


def _fill(study, n_votes: int) -> int:
    """Votes of new raters on every test item until the store holds at least ``n_votes``."""
    tests = study.keys("test")
    with sqlite3.connect(study.store.path) as con:
        have = con.execute("SELECT COUNT(*) FROM votes").fetchone()[0]
        start = con.execute("SELECT COUNT(*) FROM raters").fetchone()[0] + have
        raters = [f"fill-{start + i}" for i in range(max(0, -(-(n_votes - have) // len(tests))))]
        con.executemany("INSERT INTO votes (study, rater, item, vote, voted_at) VALUES (?, ?, ?, 1, 'x')",
                        ((study.store.study, r, k) for r in raters for k in tests))
        con.executemany("INSERT INTO history (study, rater, item, action, vote, at) VALUES "
                        "(?, ?, ?, 'vote', 1, 'x')", ((study.store.study, r, k) for r in raters for k in tests))
        return con.execute("SELECT COUNT(*) FROM votes").fetchone()[0]


def _ms(fn, repeats: int) -> float:
    fn()  # warm: the first call builds the chooser, reads the history once
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append((time.perf_counter() - t0) * 1000)
    return statistics.median(times)


def measure(sizes: list[int], *, repeats: int = 5) -> pd.DataFrame:
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench_arrival_") as tmp:
        tmp = Path(tmp)
        pairs = bench_raters.make_scene(tmp, n_frames=25)
        for sampling in ("uniform", "adaptive"):
            # votes_per_item far above the fill, so the study is never full (every arrival
            # goes through the whole check)
            study = load_study(build_study(tmp / sampling, pairs, scene=str(tmp / "scene"), tracks=4,
                                           frames_per_track=25, votes_per_item=100_000, n_training=1,
                                           n_gold=1, n_repeats=1, size=32, access="crowd",
                                           sampling=sampling, progress=False))
            tests = study.keys("test")
            for size in sizes:
                have = _fill(study, size)
                assert study.store.item_loads() == study.store.recount_loads()
                study.is_full()  # the sampler reads the new votes once, as a worker does

                def old(study=study, tests=tests):  # the check before the counters
                    return study.chooser.is_full(study.store.recount_loads(), tests)

                old_ms, new_ms = _ms(old, repeats), _ms(study.is_full, repeats)
                arrival_ms = _ms(lambda study=study: crowd_arrival(study, {}), repeats)
                rows.append({"sampling": sampling, "stored_votes": have, "test_items": len(tests),
                             "old_is_full_ms": round(old_ms, 2), "new_is_full_ms": round(new_ms, 2),
                             "old/new": round(old_ms / new_ms, 1),
                             "arrival_ms": round(arrival_ms, 2)})
                print(f"{sampling:8s} {have:8d} votes: is_full old {old_ms:7.2f} ms, new "
                      f"{new_ms:6.2f} ms ({old_ms / new_ms:.0f}x); whole arrival {arrival_ms:.2f} ms",
                      flush=True)
    return pd.DataFrame(rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--votes", default="10000,100000,1000000", help="comma list of stored votes")
    ap.add_argument("--repeats", type=int, default=5, help="timed calls per figure (median)")
    args = ap.parse_args(argv)
    table = measure([int(v) for v in args.votes.split(",")], repeats=args.repeats)
    print(table.to_string(index=False))
    big = table[table["stored_votes"] >= 1_000_000]
    verdict = ("not run" if big.empty else "met" if (big["arrival_ms"] < TARGET_MS).all() else "not met")
    print(f"target: a crowd arrival under {TARGET_MS:.0f} ms at 10^6 votes: {verdict}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
