"""A rater's load: how many items one rater sees, and about how long that takes.

Layer: annotate (rating study).

``annotate build`` prints it and caps it (``--items-per-rater``, :data:`DEFAULT_ITEMS_PER_RATER`
by default: about :data:`SESSION_MINUTES` minutes at :data:`SECONDS_PER_VOTE`).

The pace. No human rater's pace is on record in this repository; the two figures it has are
the simulated raters' response time (:mod:`annotate.simulate`: log-normal, median 0.9 s, mean
0.98 s) and the think time of the load benchmark's raters (``benchmarks/bench_raters.py``:
0.8-1.6 s, mean 1.2 s; it measures the vote-to-next-item time beside it: p50 52 ms with 3
raters, p95 under 1 s with 30). :data:`SECONDS_PER_VOTE` is the benchmark's mean think time
plus 0.3 s for the next item to appear, rounded up: 1.5 s. Recalibrate it from a real study's
``response_ms`` column (``annotate export``; the admin page shows each rater's median).

>>> DEFAULT_ITEMS_PER_RATER
800
>>> r = rater_load({"training": 5, "test": 1008, "gold": 6, "repeat": 5}, items_per_rater=800,
...                votes_per_item=5)
>>> r["items"], r["test"], r["raters_needed"], round(r["minutes"], 1)
(800, 784, 7, 20.0)
"""

from __future__ import annotations

import math

from data_schema.errors import InputError

__all__ = ["plural", "SECONDS_PER_VOTE", "SESSION_MINUTES", "DEFAULT_ITEMS_PER_RATER", "rater_load",
           "check_items_per_rater", "load_text"]

#: Seconds one vote takes a rater, item drawn to next item (see the module docstring).
SECONDS_PER_VOTE = 1.5
#: The session length the default load is made for, in minutes.
SESSION_MINUTES = 20
#: Items one rater sees at most by default: :data:`SESSION_MINUTES` at :data:`SECONDS_PER_VOTE`.
DEFAULT_ITEMS_PER_RATER = int(SESSION_MINUTES * 60 // SECONDS_PER_VOTE)

_FIXED = ("training", "gold", "repeat")


def plural(n: int, word: str, words: str | None = None) -> str:
    """``n`` and ``word`` in the number ``n`` asks for.

    Parameters
    ----------
    n : int
    word : str
        The singular.
    words : str, optional
        The plural (default ``word + 's'``).

    Returns
    -------
    str

    >>> plural(1, "vote"), plural(0, "vote"), plural(2, "rater"), plural(1, "pair")
    ('1 vote', '0 votes', '2 raters', '1 pair')
    """
    return f"{n} {word if n == 1 else (words or word + 's')}"


def check_items_per_rater(items_per_rater, counts: dict) -> int:
    """``items_per_rater`` checked against a study's item ``counts`` (by kind): room for the
    training, gold and repeat items every rater sees, and at least one test item.

    Parameters
    ----------
    items_per_rater : int
        The cap on one rater's items.
    counts : dict
        Items by kind (``training``, ``test``, ``gold``, ``repeat``).

    Returns
    -------
    int
        ``items_per_rater``.

    Raises
    ------
    InputError
        Naming ``items_per_rater``.

    >>> check_items_per_rater(10, {"training": 5, "gold": 2, "repeat": 3, "test": 40})
    Traceback (most recent call last):
    ...
    data_schema.errors.InputError: items_per_rater: expected more than the 10 training, gold and repeat items each rater sees, got 10
    """
    fixed = sum(int(counts.get(k, 0)) for k in _FIXED)
    if isinstance(items_per_rater, bool) or not isinstance(items_per_rater, int) or items_per_rater <= fixed:
        raise InputError(param="items_per_rater", expected=f"more than the {fixed} training, gold and "
                         "repeat items each rater sees", got=items_per_rater)
    return items_per_rater


def rater_load(counts: dict, *, items_per_rater: int | None, votes_per_item: int) -> dict:
    """One rater's load in a study with item ``counts`` (by kind).

    Parameters
    ----------
    counts : dict
        Items by kind (``training``, ``test``, ``gold``, ``repeat``; the manifest's ``counts``).
    items_per_rater : int or None
        The cap on a rater's items, training, gold and repeats included (None: every item).
    votes_per_item : int
        The votes each test item collects.

    Returns
    -------
    dict
        ``items`` (at most, per rater), ``test`` (test items among them), ``minutes`` (``items``
        at :data:`SECONDS_PER_VOTE`), ``raters_needed`` (raters who, each seeing ``test`` test
        items, give every test item its ``votes_per_item`` votes).
    """
    fixed = sum(int(counts.get(k, 0)) for k in _FIXED)
    n_test = int(counts.get("test", 0))
    test = n_test if items_per_rater is None else max(0, min(n_test, items_per_rater - fixed))
    items = fixed + test
    needed = math.ceil(n_test * votes_per_item / test) if test else 0
    return {"items": items, "test": test, "minutes": items * SECONDS_PER_VOTE / 60,
            "raters_needed": needed}


def load_text(load: dict, *, votes_per_item: int) -> str:
    """The line ``annotate build`` prints about :func:`rater_load`'s result.

    Parameters
    ----------
    load : dict
        :func:`rater_load`'s result (``items``, ``test``, ``minutes``, ``raters_needed``).
    votes_per_item : int
        Votes wanted per test item.

    Returns
    -------
    str

    >>> load_text({"items": 800, "test": 784, "minutes": 20.0, "raters_needed": 7}, votes_per_item=5)
    'each rater: up to 800 items (784 of them test items), about 20 min at 1.5 s per vote; 7 raters give every test item its 5 votes'
    """
    return (f"each rater: up to {load['items']} items ({load['test']} of them test items), about "
            f"{load['minutes']:.0f} min at {SECONDS_PER_VOTE:g} s per vote; "
            f"{plural(load['raters_needed'], 'rater')} give{'s' if load['raters_needed'] == 1 else ''} "
            "every test item its "
            f"{plural(votes_per_item, 'vote')}")
