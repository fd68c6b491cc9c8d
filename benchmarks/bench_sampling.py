"""Active and adaptive rating designs against uniform ones, on simulated raters with known truth.

Pairwise: 6 methods with known JOD spacing (``--spacing``, default 1 JOD between neighbours,
plus an item jitter of 0.3 JOD) over 40 items. Raters are :mod:`annotate.simulate`'s
pairwise raters in JOD units: a careful rater answers by
:func:`annotate.simulate.p_choice` of the true JOD difference with its own indifference
half-width ``tie ~ U(0.01, 0.05)``, logistic width ``~ U(0.8, 1.0)`` (1 JOD ~ 75%: the
logistic of width 1 / ln 3 = 0.91) and lapse 0.02; one rater in ten is careless (left or
right at random). Each vote comes from a rater drawn at random. The full uniform design
shows every (item, pair) ``--reps`` times (40 x 15 x 3 = 1,800 comparisons) in rounds, in a
random order; the active design asks :func:`annotate.sampling.select_batch` for
``--batch`` comparisons at a time (that many raters busy at once) and updates the posterior
with their votes. At each sixteenth of the full budget both designs' votes are scaled per item with
:func:`analysis.stats.jod.jod_map` (Gaussian prior, sd 2.5 JOD; ``--scale pwcmp``:
:func:`analysis.stats.jod.jod_scale`, pwcmp's prior, which leaves sparse unanimous designs nearly
unconstrained and is slow), and compared with the truth (both
centred per item): RMSE in JOD and the mean per-item Kendall tau.

Binary: ``--items`` items whose severity is uniform in [0, 1]; raters are
:func:`annotate.simulate.p_good` raters (threshold ``~ N(0.45, 0.08)``, width ``~ U(0.04,
0.12)``, lapse 0.02), one in ten careless (good with probability 0.5). P(good) of an item is
the mean over the rater pool; the true label is ``P(good) >= 0.5``. Each item has one
sequence of answers (a random rater each) that both designs read in order, so they differ
only in how many they read: the full uniform design reads ``--votes-per-item`` of every item;
the adaptive one follows :func:`annotate.sampling.next_binary_items` (curtailed at the quota,
freed votes to the most uncertain GVF, up to ``--max-votes-per-item``; several caps are
compared, default 5, 7 and 9).

Prints medians over ``--seeds`` seeds (default 20): per budget, both designs side by side,
then the votes each needed to reach the full uniform design's accuracy, the acceptance
targets of issue 37, and the selection time per call.

    python benchmarks/bench_sampling.py              # 20 seeds
    python benchmarks/bench_sampling.py --seeds 2    # quick look
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.stats import kendalltau

from analysis.stats.jod import jod_map, jod_scale
from annotate.sampling import (
    next_binary_items,
    pair_posterior,
    select_batch,
    update_pairwise,
)
from annotate.simulate import p_choice, p_good

N_METHODS = 6
FRACTIONS = np.arange(1, 17) / 16


# --- pairwise ------------------------------------------------------------------------------

def _raters(rng, n: int) -> list[dict]:
    out = []
    for r in range(n):
        out.append({"careless": r % 10 == 9, "tie": rng.uniform(0.01, 0.05), "width": rng.uniform(0.8, 1.0)})
    return out


def _answer(rng, rater: dict, s_a: float, s_b: float) -> float:
    """1: a preferred, 0: b, 0.5: can't tell."""
    u = rng.random()
    if rater["careless"]:
        return 1.0 if u < 0.5 else 0.0
    pa, pb, _ = p_choice(s_a - s_b, tie=rater["tie"], width=rater["width"], lapse=0.02)
    return 1.0 if u < pa else (0.0 if u < pa + pb else 0.5)


def _scale_errors(votes: list, truth: np.ndarray, scale: str) -> tuple[float, float]:
    """RMSE (JOD) and mean Kendall tau of the per-item JOD scales of ``votes`` (item, a, b, s)."""
    n_items, m = truth.shape
    d = np.zeros((n_items, m, m))
    for it, a, b, s in votes:
        d[it, a, b] += s
        d[it, b, a] += 1.0 - s
    q = jod_map(d) if scale == "map" else jod_scale(d)
    q = q - np.nanmean(q, axis=1, keepdims=True)
    q = np.nan_to_num(q)
    t = truth - truth.mean(axis=1, keepdims=True)
    rmse = float(np.sqrt(np.mean((q - t) ** 2)))
    # an item whose estimate is still constant (no votes yet) has no ranking: tau 0, not NaN
    tau = float(np.mean(np.nan_to_num([kendalltau(q[i], t[i]).statistic for i in range(n_items)])))
    return rmse, tau


def _uniform_pairs(rng, n_items: int, reps: int) -> list[tuple[int, int, int]]:
    i, j = np.triu_indices(N_METHODS, 1)
    cells = [(it, int(a), int(b)) for it in range(n_items) for a, b in zip(i, j, strict=True)]
    out = []
    for _ in range(reps):  # rounds: every prefix is nearly balanced
        out += [cells[k] for k in rng.permutation(len(cells))]
    return out


def run_pairwise(seed: int, *, n_items: int, reps: int, batch: int, spacing: float, scale: str) -> dict:
    rng = np.random.default_rng(seed)
    truth = spacing * np.arange(N_METHODS)[None, :] + rng.normal(0, 0.3, (n_items, N_METHODS))
    raters = _raters(rng, 20)
    budget = n_items * N_METHODS * (N_METHODS - 1) // 2 * reps
    checks = [int(round(f * budget)) for f in FRACTIONS]
    uni = []
    for it, a, b in _uniform_pairs(rng, n_items, reps):
        uni.append((it, a, b, _answer(rng, raters[rng.integers(len(raters))], truth[it, a], truth[it, b])))
    res = {"uniform": [_scale_errors(uni[:c], truth, scale) for c in checks]}
    post, act, times = pair_posterior(n_items, N_METHODS), [], []
    while len(act) < budget:
        t0 = time.process_time()   # CPU time: the machine may be shared, wall time moves with it
        chosen = select_batch(post, min(batch, budget - len(act)), rng=rng)
        times.append((time.process_time() - t0) * 1e3)
        for it, a, b in chosen:
            s = _answer(rng, raters[rng.integers(len(raters))], truth[it, a], truth[it, b])
            act.append((it, a, b, s))
        for it, a, b, s in act[-len(chosen):]:
            post = update_pairwise(post, it, a, b, s)
    res["active"] = [_scale_errors(act[:c], truth, scale) for c in checks]
    res["select_ms"] = float(np.median(times))
    return res


# --- binary --------------------------------------------------------------------------------

def run_binary(seed: int, *, n_items: int, votes_per_item: int, max_votes: int) -> dict:
    rng = np.random.default_rng(seed + 10_000)
    sev = rng.uniform(0, 1, n_items)
    n_r = 20
    theta, width = rng.normal(0.45, 0.08, n_r), rng.uniform(0.04, 0.12, n_r)
    careless = np.arange(n_r) % 10 == 9
    pg = np.where(careless[:, None], 0.5, p_good(sev[None, :], theta=theta[:, None], width=width[:, None],
                                                 lapse=0.02))          # (R, N)
    truth = pg.mean(0) >= 0.5
    who = rng.integers(0, n_r, (n_items, max_votes))
    answers = rng.random((n_items, max_votes)) < pg[who, np.arange(n_items)[:, None]]   # (N, max)
    full = answers[:, :votes_per_item].sum(1) * 2 >= votes_per_item                     # gvf >= 0.5
    budget = n_items * votes_per_item
    good, bad, spent, times, curve = np.zeros(n_items, int), np.zeros(n_items, int), 0, [], {}
    checks = {int(round(f * budget)): f for f in np.arange(0.30, 1.0001, 0.05)}
    while spent < budget:
        t0 = time.process_time()
        nxt = next_binary_items(good, bad, votes_per_item=votes_per_item, max_votes_per_item=max_votes, k=1)
        times.append((time.process_time() - t0) * 1e3)
        if nxt.size == 0:
            break
        it = nxt[0]
        v = answers[it, good[it] + bad[it]]
        good[it] += v
        bad[it] += 1 - v
        spent += 1
        if spent in checks:
            curve[checks[spent]] = _binary_state(good, bad, full, truth)
    final = _binary_state(good, bad, full, truth)
    for f in checks.values():  # every item closed before the budget: the labels stay as they are
        curve.setdefault(f, final)
    return {"curve": curve, "spent": spent / budget, "uniform_truth": float((full == truth).mean()),
            "select_ms": float(np.median(times))}


def _binary_state(good, bad, full, truth) -> tuple[float, float]:
    label = good >= bad           # gvf >= 0.5 (an item without votes would count as good)
    return float((label == full).mean()), float((label == truth).mean())


# --- report --------------------------------------------------------------------------------

def _first(curve, target, better) -> float:
    """Smallest budget fraction whose value reaches ``target`` (inf when none)."""
    for f, v in curve:
        if better(v, target):
            return f
    return float("inf")


def plot_pairwise(u: np.ndarray, a: np.ndarray, budget: int, path: str) -> None:
    """RMSE and Kendall tau against comparisons, both designs (medians over seeds)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 3.2), layout="constrained")
    x = FRACTIONS * budget
    for ax, k, name in zip(fig.subplots(1, 2), (0, 1), ("RMSE of the JOD scale", "Kendall tau (per item)"),
                           strict=True):
        ax.plot(x, np.median(u[:, :, k], 0), "o-", ms=3, label="uniform")
        ax.plot(x, np.median(a[:, :, k], 0), "o-", ms=3, label="active")
        ax.set_xlabel("comparisons")
        ax.set_ylabel(name)
        ax.grid(alpha=0.3)
    fig.axes[0].legend()
    fig.savefig(path)
    print(f"plot: {path}")


def report_pairwise(runs: list[dict], reps: int, n_items: int, plot: str | None = None) -> None:
    budget = n_items * N_METHODS * (N_METHODS - 1) // 2 * reps
    u = np.array([r["uniform"] for r in runs])   # (S, F, 2)
    a = np.array([r["active"] for r in runs])
    print(f"\nPairwise: {n_items} items x {N_METHODS} methods, full uniform budget {budget} comparisons; "
          f"medians over {len(runs)} seeds")
    print(f"{'budget':>8} {'votes':>6} | {'RMSE uniform':>12} {'RMSE active':>11} | {'tau uniform':>11} {'tau active':>10}")
    for k, f in enumerate(FRACTIONS):
        print(f"{f:8.3f} {int(round(f * budget)):6d} | {np.median(u[:, k, 0]):12.3f} {np.median(a[:, k, 0]):11.3f} | "
              f"{np.median(u[:, k, 1]):11.3f} {np.median(a[:, k, 1]):10.3f}")
    need = [_first(list(zip(FRACTIONS, a[s, :, 0], strict=True)), u[s, -1, 0], lambda v, t: v <= t)
            for s in range(len(runs))]
    need_u = [_first(list(zip(FRACTIONS, u[s, :, 0], strict=True)), u[s, -1, 0], lambda v, t: v <= t)
              for s in range(len(runs))]
    med = float(np.median(need))
    print(f"votes to reach the full uniform design's RMSE: uniform {np.median(need_u):.3f} of the budget, "
          f"active {med:.3f} (median over seeds; inf: never within the budget)")
    tau_ok = [np.median(a[:, k, 1]) >= np.median(u[:, k, 1]) for k in range(len(FRACTIONS))]
    print(f"target: active reaches uniform's final RMSE with <= 0.5 of the comparisons: "
          f"{'MET' if med <= 0.5 else 'NOT MET'} ({med:.3f})")
    print(f"target: active Kendall tau >= uniform's at equal budget: "
          f"{'MET' if all(tau_ok) else 'NOT MET'} at {sum(tau_ok)} of {len(tau_ok)} budgets")
    if plot:
        plot_pairwise(u, a, budget, plot)
    print(f"pairwise selection (select_batch of {N_METHODS} methods x {n_items} items, --batch per call): "
          f"median {np.median([r['select_ms'] for r in runs]):.2f} ms CPU per call")


def report_binary(runs: list[dict], args, cap: int) -> None:
    fr = sorted(runs[0]["curve"])
    m = np.array([[r["curve"][f] for f in fr] for r in runs])   # (S, F, 2)
    print(f"\nBinary: {args.items} items, uniform {args.votes_per_item} votes per item "
          f"({args.items * args.votes_per_item} votes), adaptive up to {cap} per item; "
          f"medians over {len(runs)} seeds")
    print(f"full uniform: majority = truth on {np.median([r['uniform_truth'] for r in runs]):.3f} of items")
    print(f"{'budget':>8} | {'adaptive = uniform majority':>27} {'adaptive = truth':>16}")
    for k, f in enumerate(fr):
        print(f"{f:8.2f} | {np.median(m[:, k, 0]):27.3f} {np.median(m[:, k, 1]):16.3f}")
    need97 = [_first(list(zip(fr, m[s, :, 0], strict=True)), 0.97, lambda v, t: v >= t) for s in range(len(runs))]
    need_truth = [_first(list(zip(fr, m[s, :, 1], strict=True)), runs[s]["uniform_truth"], lambda v, t: v >= t)
                  for s in range(len(runs))]
    print(f"votes to match the full uniform majority on >= 97% of items: {np.median(need97):.2f} of uniform's")
    print(f"votes to reach the full uniform design's accuracy against the truth: {np.median(need_truth):.2f}")
    print(f"adaptive spent {np.median([r['spent'] for r in runs]):.3f} of the budget before every item was closed")
    ok = np.median(need97) <= 0.65
    print(f"target: adaptive = full uniform majority on >= 97% with <= 65% of its votes: "
          f"{'MET' if ok else 'NOT MET'} ({np.median(need97):.2f})")
    print(f"binary selection (next_binary_items over {args.items} items): median "
          f"{np.median([r['select_ms'] for r in runs]):.3f} ms CPU per call")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--items", type=int, default=400, help="binary items (default 400)")
    ap.add_argument("--pair-items", type=int, default=40, help="pairwise items (default 40)")
    ap.add_argument("--reps", type=int, default=3, help="uniform repetitions of every (item, pair)")
    ap.add_argument("--batch", type=int, default=4, help="comparisons chosen at once (raters busy)")
    ap.add_argument("--spacing", type=float, default=1.0, help="JOD between neighbouring methods")
    ap.add_argument("--votes-per-item", type=int, default=5)
    ap.add_argument("--max-votes-per-item", default="5,7,9", help="adaptive caps to compare (comma list)")
    ap.add_argument("--scale", choices=["map", "pwcmp"], default="map",
                    help="scale estimator: analysis.stats.jod.jod_map (Gaussian prior, sd 2.5 JOD; default) or "
                         "jod_scale (pwcmp's prior; slow and unstable on sparse designs)")
    ap.add_argument("--plot", default=None, help="save the pairwise curves here (PNG or SVG)")
    ap.add_argument("--only", choices=["pairwise", "binary"], default=None)
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    if args.only != "binary":
        runs = []
        for s in range(args.seeds):
            runs.append(run_pairwise(s, n_items=args.pair_items, reps=args.reps, batch=args.batch,
                                     spacing=args.spacing, scale=args.scale))
            print(f"pairwise seed {s + 1}/{args.seeds} done ({time.perf_counter() - t0:.0f} s)", flush=True)
        report_pairwise(runs, args.reps, args.pair_items, args.plot)
    if args.only != "pairwise":
        for cap in [int(c) for c in str(args.max_votes_per_item).split(",")]:
            runs = [run_binary(s, n_items=args.items, votes_per_item=args.votes_per_item, max_votes=cap)
                    for s in range(args.seeds)]
            report_binary(runs, args, cap)


if __name__ == "__main__":
    main()
