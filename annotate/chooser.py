"""Which item a rater sees next: one walk through the rater's plan, for every sampling.

Layer: annotate (rating study). The plans are :mod:`annotate.assign`'s; the designs
(:mod:`annotate.binary`, :mod:`annotate.pairwise`) supply the items; the samplers
(:mod:`annotate.study_sampling`) choose among test items. Everything else about the next
item is decided here, once: :meth:`Chooser.next` picks, in this order,

1. the next training item (the study's order);
2. a special that is due and open (a repeat once the rater voted on its original; a gold
   item of the study's pool while its cap allows, :meth:`Chooser.gold_open`);
3. a test item, while the rater has had fewer than the plan's ``max_tests``: the
   sampling's choice among the test items the rater has not had (:meth:`Chooser.test`);
4. when no test item is left for the rater, the rater is done: still shown are the repeats
   whose original it voted on, and gold only up to its plan's gold in proportion to the test
   items it had (rounded up; none without a test item; an adaptive study once served 16
   of 24 raters nothing but gold once its test items had closed, which marks them as gold).
   Plans made before the gold pool (no ``gold_quota``) still show every gold item.

**The gold cap.** Counting the identities that saw an
item must not tell gold from test items, so a gold item's exposure follows the test
items'. Under ``uniform`` sampling every test item reaches ``votes_per_item`` raters, and
so may a gold item. Under ``active`` and ``adaptive`` sampling test items reach different
numbers of raters; each gold item then *shadows* one test item (its partner, a seeded
draw over the test items without repeats while there are enough, so the partners are a
sample of the test items) and is shown only while fewer raters hold or voted it than hold
or voted its partner. No gold item then reaches more raters than its partner, and their
exposures are distributed as the partners' are.

``loads`` is, per item, its standing votes plus the live claims of other raters (the
store's, :meth:`annotate.store.Store.next_item`).

>>> plan = {"training": ["t1"], "order": ["a", "b", "c"], "specials": [[1, "g1"]],
...         "repeat_of": {}}
>>> ch = UniformChooser(quota=2)
>>> ch.next(RaterState(plan, [], set(), {}))
't1'
>>> ch.next(RaterState(plan, ["t1"], {"t1"}, {"a": 2, "b": 1}))  # a full; c has the lowest load
'c'
>>> ch.next(RaterState(plan, ["t1", "c"], {"t1", "c"}, {"a": 2, "b": 1}))  # g1 due after 1 test
'g1'
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from annotate.study_sampling import PairwiseSampler, make_sampler
from data_schema.vocab import ItemKind

__all__ = ["RaterState", "Chooser", "UniformChooser", "SampledChooser", "ActiveChooser",
           "AdaptiveChooser", "make_chooser", "gold_partners", "choose_next"]


@dataclass(frozen=True)
class RaterState:
    """What the next choice depends on.

    Attributes
    ----------
    plan : dict
        The rater's plan (:func:`annotate.assign.make_plan`).
    assigned : list of str
        Keys already handed to the rater, in order.
    voted : set of str
        Keys the rater voted on.
    loads : dict
        Item key -> standing votes plus other raters' live claims.
    """

    plan: dict
    assigned: list[str]
    voted: set[str]
    loads: dict[str, int]


class Chooser:
    """The walk through a rater's plan (module docstring); a sampling supplies
    :meth:`test`, :meth:`test_room` and :meth:`gold_open`.

    ``observe``: the callable the store gives its history reader before each choice
    (:meth:`annotate.store.Store.next_item`), or None.
    """

    observe: Callable | None = None

    def test(self, open_keys: list[str], loads: dict[str, int]) -> str | None:
        """The test item to hand out among ``open_keys`` (the rater's own order), or None."""
        raise NotImplementedError

    def test_room(self, open_keys: list[str], loads: dict[str, int]) -> int:
        """How many of ``open_keys`` the sampling may still hand out (for progress)."""
        raise NotImplementedError

    def gold_open(self, key: str, loads: dict[str, int]) -> bool:
        """Whether gold item ``key`` of the pool may reach one more rater."""
        raise NotImplementedError

    def refresh(self, rows_after) -> None:
        """Bring the sampling's state up to the store's history (``rows_after(watermark)``)."""
        if self.observe is not None:
            self.observe(rows_after)

    # -- the walk ---------------------------------------------------------------------------
    def _special_open(self, plan: dict, key: str, voted: set[str], loads: dict[str, int]) -> bool:
        original = plan["repeat_of"].get(key)
        if original is not None:
            return original in voted
        return not plan.get("gold_quota") or self.gold_open(key, loads)

    def next(self, state: RaterState) -> str | None:
        """The rater's next item key, or None when the rater is done (or must wait).

        Parameters
        ----------
        state : RaterState
            The rater's plan, items and the loads.

        Returns
        -------
        str or None
        """
        plan, done, voted, loads = state.plan, set(state.assigned), state.voted, state.loads
        for key in plan["training"]:
            if key not in done:
                return key
        order = plan["order"]
        n_tests = sum(1 for k in order if k in done)
        specials = [(after, key) for after, key in plan["specials"] if key not in done]
        for after, key in specials:
            if after <= n_tests and self._special_open(plan, key, voted, loads):
                return key
        if n_tests < plan.get("max_tests", n_tests + 1):  # the rater's share is not done
            best = self.test([k for k in order if k not in done], loads)
            if best is not None:
                return best
        share = _gold_share(plan, n_tests, done)
        for _after, key in specials:
            if (key in plan["repeat_of"] or share > 0) and self._special_open(plan, key, voted, loads):
                return key
        return None

    def total(self, state: RaterState) -> int:
        """How many non-training items the rater will have seen when done, as far as known now:
        the items assigned, the test items the sampling may still give the rater (at most its
        share), the gold items still open and due within that many tests, the repeats whose
        original is done or still to come.

        Parameters
        ----------
        state : RaterState
            ``loads``: the other raters' standing votes on the items the rater has open.

        Returns
        -------
        int
        """
        plan, loads = state.plan, state.loads
        done = set(state.assigned)
        training = set(plan["training"])
        n = sum(1 for k in state.assigned if k not in training)
        open_keys = [k for k in plan["order"] if k not in done]
        n_tests = len(plan["order"]) - len(open_keys)
        more = self.test_room(open_keys, loads)
        if "max_tests" in plan:
            more = min(more, max(plan["max_tests"] - n_tests, 0))
        end, n = n_tests + more, n + more
        open_set = set(open_keys)
        share = _gold_share(plan, end, done)
        for after, key in plan["specials"]:
            if key in done:
                continue
            original = plan["repeat_of"].get(key)
            if original is not None:
                n += original in done or (more > 0 and original in open_set)
            elif not plan.get("gold_quota") or (self.gold_open(key, loads) and (
                    after <= end or share > 0)):  # (specials are in the order they are due)
                share -= 1
                n += 1
        return n

    def votes_left(self, loads: dict[str, int], tests: list[str]) -> int:
        """How many more test votes the study takes (``loads``: standing votes)."""
        raise NotImplementedError

    def is_full(self, loads: dict[str, int], tests: list[str]) -> bool:
        """Whether a new rater would be given no test item (``loads``: standing votes)."""
        return self.test(list(tests), loads) is None


def _gold_share(plan: dict, n_tests: int, done: set[str]) -> int:
    """Gold items a rater whose test items ran out after ``n_tests`` may still be shown
    beyond those due: its plan's gold in proportion to the tests it had (rounded up; none
    without a test item), less the gold it was shown. Plans made before the gold pool (no
    ``gold_quota``) show every gold item."""
    golds = [key for _after, key in plan["specials"] if key not in plan["repeat_of"]]
    if not plan.get("gold_quota"):
        return len(golds)
    positions = max(min(len(plan["order"]), plan.get("max_tests", len(plan["order"]))), 1)
    allowed = -(-n_tests * len(golds) // positions)  # ceil
    return allowed - sum(1 for key in golds if key in done)


class UniformChooser(Chooser):
    """Uniform sampling: the open test item with the fewest loads below ``quota``, ties by
    the rater's order, so every item reaches its quota before any gets more; a gold item of
    the pool, like a test item, reaches at most ``quota`` raters.

    Parameters
    ----------
    quota : int
        ``votes_per_item``.
    """

    def __init__(self, quota: int) -> None:
        self.quota = int(quota)

    def test(self, open_keys, loads):
        best, best_load = None, None
        for key in open_keys:
            load = loads.get(key, 0)
            if load >= self.quota:
                continue
            if best_load is None or load < best_load:
                best, best_load = key, load
                if load == 0:
                    break
        return best

    def test_room(self, open_keys, loads):
        return sum(1 for k in open_keys if loads.get(k, 0) < self.quota)

    def gold_open(self, key, loads):
        return loads.get(key, 0) < self.quota

    def votes_left(self, loads, tests):
        return sum(max(self.quota - loads.get(k, 0), 0) for k in tests)


def gold_partners(tests: list[str], golds: list[str], *, seed: int) -> dict[str, str]:
    """Each gold item's partner test item (the one whose exposure it shadows): a seeded
    permutation of the test items, taken in turn (distinct partners while there are at
    least as many test items as gold items).

    Parameters
    ----------
    tests, golds : list of str
        The study's test and gold keys.
    seed : int
        The study's seed.

    Returns
    -------
    dict
        Gold key -> test key (empty without test items).

    >>> p = gold_partners(["a", "b", "c"], ["g1", "g2"], seed=0)
    >>> sorted(p) == ["g1", "g2"] and len(set(p.values())) == 2 and set(p.values()) <= {"a", "b", "c"}
    True
    """
    if not tests:
        return {}
    rng = np.random.default_rng([int(seed), 5])
    perm = rng.permutation(len(tests))
    return {g: tests[int(perm[i % len(tests)])] for i, g in enumerate(golds)}


class SampledChooser(Chooser):
    """A sampler's choice among the test items (:mod:`annotate.study_sampling`); a gold item
    shadows its partner test item (:func:`gold_partners`).

    Parameters
    ----------
    sampler : annotate.study_sampling._Sampler
        The study's sampler (``pick``, ``room``, ``refresh``).
    partners : dict
        Gold key -> test key.
    """

    def __init__(self, sampler, partners: dict[str, str]) -> None:
        self.sampler = sampler
        self.partners = dict(partners)
        self.observe = sampler.refresh

    def test(self, open_keys, loads):
        return self.sampler.pick(open_keys, loads)

    def test_room(self, open_keys, loads):
        return self.sampler.room(open_keys, loads)

    def votes_left(self, loads, tests):
        return self.sampler.votes_left(loads)

    def gold_open(self, key, loads):
        partner = self.partners.get(key)
        return partner is not None and loads.get(key, 0) < loads.get(partner, 0)


class ActiveChooser(SampledChooser):
    """Active pairwise sampling (:class:`annotate.study_sampling.PairwiseSampler`)."""


class AdaptiveChooser(SampledChooser):
    """Adaptive binary sampling (:class:`annotate.study_sampling.BinarySampler`)."""


def make_chooser(study) -> Chooser:
    """The study's chooser: uniform, active or adaptive (its manifest's ``sampling``).

    Parameters
    ----------
    study : annotate.study.Study
        The loaded study.

    Returns
    -------
    Chooser
    """
    sampler = make_sampler(study)
    if sampler is None:
        return UniformChooser(study.quota)
    partners = gold_partners(study.keys(ItemKind.TEST), study.keys(ItemKind.GOLD), seed=study.manifest.seed)
    kind = ActiveChooser if isinstance(sampler, PairwiseSampler) else AdaptiveChooser
    return kind(sampler, partners)


def choose_next(plan: dict, assigned: list[str], voted: set[str], loads: dict[str, int], *,
                quota: int) -> str | None:
    """The next item of a uniform study's rater (:meth:`UniformChooser.next`), for callers
    that hold a plan and a store but no study.

    Parameters
    ----------
    plan : dict
        The rater's plan.
    assigned : list of str
        Keys already assigned to the rater.
    voted : set of str
        Keys it voted on.
    loads : dict
        Item key -> votes plus live claims of the other raters.
    quota : int
        Votes wanted per test item.

    Returns
    -------
    str or None
    """
    return UniformChooser(quota).next(RaterState(plan, assigned, voted, loads))
