"""Per-rater plans: the order of a rater's items, its gold draw and repeats (pure functions).

Layer: annotate (rating study).

A rater's *plan* is fixed when the rater signs in for the first time and stored with the
rater: the training items in study order, then the test items in a random order seeded by
an HMAC of the study seed and the rater id under the study's secret (:func:`plan_seed`),
and the hidden gold (the rater's draw from the study's gold pool, :func:`draw_gold`) and
repeat items ("specials"), each due after a seeded number of test items. Which item a
rater gets next, given its plan and the other raters' loads, is :mod:`annotate.chooser`'s
(one walk for every sampling: training, specials due, a test item, the end of the plan;
the gold pool's cap).
"""

from __future__ import annotations

import hashlib
import hmac

import numpy as np

from data_schema.vocab import Side

__all__ = ["make_plan", "draw_gold", "rater_seed", "plan_seed", "pairwise_sides"]


def rater_seed(study_seed: int, rater: str) -> int:
    """A 63-bit seed from the study seed and the rater id (stable across runs and machines).

    Unkeyed: anyone who knows the seed computes it. Plans use :func:`plan_seed` (keyed with
    the study's secret); this stays for callers that want a public, reproducible seed.

    Parameters
    ----------
    study_seed : int
        The study's seed.
    rater : str
        The rater id.

    Returns
    -------
    int
        A non-negative seed below ``2**63``, from SHA-256 of ``"seed:rater"``.

    >>> rater_seed(0, "ann") == rater_seed(0, "ann") != rater_seed(1, "ann")
    True
    """
    digest = hashlib.sha256(f"{int(study_seed)}:{rater}".encode()).digest()
    return int.from_bytes(digest[:8], "little") >> 1


def plan_seed(secret: str, study_seed: int, rater: str) -> int:
    """A 63-bit plan seed keyed with the study's secret: HMAC-SHA256 of the study seed and
    the rater id. Without the secret nobody can compute a rater's order and gold positions
    (``sha256(seed:rater)`` with the README's seed 0 predicted 42 of 48 gold
    positions).

    Parameters
    ----------
    secret : str
        The study's secret (its admin token, ``secrets.json``).
    study_seed : int
        The manifest's seed.
    rater : str
        The rater id.

    Returns
    -------
    int
        The seed, in [0, 2**63).

    >>> plan_seed("k", 0, "ann") == plan_seed("k", 0, "ann") != plan_seed("j", 0, "ann")
    True
    """
    digest = hmac.new(str(secret).encode(), f"plan|{int(study_seed)}|{rater}".encode(),
                      hashlib.sha256).digest()
    return int.from_bytes(digest[:8], "little") >> 1


def draw_gold(golds: list[str], n: int, *, seed: int) -> list[str]:
    """The ``n`` gold items of one rater, drawn from the study's pool ``golds``.

    Each kind of gold (the key's prefix before ``:``, e.g. ``gold-good`` and ``gold-bad``)
    is shuffled by a stream of the rater's seed of its own (the plan's draws are unchanged)
    and the kinds are taken in turn, so a rater gets as many of each as the pool allows.
    With a pool :data:`annotate.design.GOLD_POOL` times ``n``, an item of the pool reaches
    about one rater in that many (when every rater saw every gold item,
    counting the identities that saw an item found them all).

    Parameters
    ----------
    golds : list of str
        The pool's gold item keys.
    n : int
        Gold items the rater is shown (all of ``golds`` when ``n >= len(golds)``).
    seed : int
        The rater's seed (:func:`plan_seed`, keyed with the study's secret).

    Returns
    -------
    list of str
        ``min(n, len(golds))`` keys, kinds in turn.

    >>> pool = [f"gold-good:{i}" for i in range(4)] + [f"gold-bad:{i}" for i in range(4)]
    >>> got = draw_gold(pool, 4, seed=7)
    >>> sorted(k.split(":")[0] for k in got), draw_gold(pool, 4, seed=7) == got
    (['gold-bad', 'gold-bad', 'gold-good', 'gold-good'], True)
    """
    rng = np.random.default_rng([int(seed), 3])
    kinds: dict[str, list[str]] = {}
    for key in golds:
        kinds.setdefault(key.split(":", 1)[0], []).append(key)
    queues = [[group[i] for i in rng.permutation(len(group))] for group in kinds.values()]
    out: list[str] = []
    while len(out) < min(int(n), len(golds)):
        for queue in queues:
            if queue and len(out) < n:
                out.append(queue.pop())
    return out


def make_plan(*, training: list[str], tests: list[str], golds: list[str],
              repeats: dict[str, str], seed: int, max_tests: int | None = None,
              n_gold: int | None = None) -> dict:
    """The rater's plan (JSON-able dict).

    ``repeats`` maps a repeat item key to its original test item key. Gold items are spread
    over the whole test sequence; a repeat is due at least a quarter of the sequence after
    a random point, so it rarely follows its original closely. ``max_tests``: the most test
    items the rater is given (None: no cap; the plan's ``max_tests``); the sequence the
    specials are spread over is then that long.

    Parameters
    ----------
    training : list of str
        Training item keys, shown first in this order.
    tests : list of str
        Test item keys.
    golds : list of str
        Gold item keys.
    repeats : dict
        Repeat item key -> its original test item key.
    seed : int
        The rater's seed (:func:`rater_seed`).
    max_tests : int, optional
        Cap on the rater's test items.
    n_gold : int, optional
        Gold items the rater is shown, drawn from the pool ``golds`` (:func:`draw_gold`;
        the plan gets ``gold_quota``: :mod:`annotate.chooser` caps them); None:
        every one (studies built before the pool).

    Returns
    -------
    dict
        The plan.
    """
    if n_gold is not None:
        golds = draw_gold(golds, n_gold, seed=seed)
    rng = np.random.default_rng(seed)
    order = [tests[i] for i in rng.permutation(len(tests))]
    n = max(len(order) if max_tests is None else min(len(order), max_tests), 1)
    specials = [[int(rng.integers(1, n + 1)), g] for g in golds]
    specials += [[int(min(n, rng.integers(1, n + 1) + n // 4)), r] for r in sorted(repeats)]
    specials.sort(key=lambda s: (s[0], s[1]))
    plan = {"training": list(training), "order": order, "specials": specials,
            "repeat_of": dict(repeats)}
    if max_tests is not None:
        plan["max_tests"] = int(max_tests)
    if n_gold is not None:  # a pool's gold, like a test item, reaches at most `quota` raters
        plan["gold_quota"] = True
    return plan


def pairwise_sides(plan: dict, *, seed: int) -> dict[str, str]:
    """The side (``'left'``/``'right'``) method A is shown on, per item of a pairwise plan.

    Counterbalanced within the rater: of the training, the test and the gold items, each
    group has A on the left for half of its items (a seeded shuffle; an odd group's extra
    item gets a random side), so a rater who always presses one side cannot favour a method.
    A repeat shows A on the side opposite to its original, so a side-biased rater answers
    the two differently. Across raters, an item's side is a fair coin.

    Parameters
    ----------
    plan : dict
        The rater's plan (:func:`make_plan`).
    seed : int
        The rater's seed.

    Returns
    -------
    dict
        Item key -> ``{'left', 'right'}``.

    >>> plan = make_plan(training=["t"], tests=["a", "b", "c", "d"], golds=["g1", "g2"],
    ...                  repeats={"r:a": "a"}, seed=1)
    >>> sides = pairwise_sides(plan, seed=1)
    >>> sorted(str(sides[k]) for k in "abcd"), sorted(str(sides[k]) for k in ("g1", "g2"))
    (['left', 'left', 'right', 'right'], ['left', 'right'])
    >>> sides["r:a"] != sides["a"]
    True
    """
    rng = np.random.default_rng([int(seed), 2])  # a stream of its own: the plan's is unchanged
    golds = [key for _after, key in plan["specials"] if key not in plan["repeat_of"]]
    sides: dict[str, str] = {}
    for group in (plan["training"], plan["order"], golds):
        left = (rng.permutation(len(group)) + int(rng.integers(2))) % 2 == 0
        sides.update({key: Side.LEFT if lf else Side.RIGHT for key, lf in zip(group, left, strict=True)})
    for key, original in plan["repeat_of"].items():
        sides[key] = Side.RIGHT if sides[original] == Side.LEFT else Side.LEFT
    return sides
