"""Where a study's next vote goes while it is served: ``annotate build --sampling``.

Layer: annotate (rating study; serving). The pure selection rules are
:mod:`annotate.sampling`; this module keeps their state for one server process and feeds
it from the vote store.

- ``uniform`` (the binary default, and every study built before ``--sampling`` existed):
  each test item gets ``votes_per_item`` votes, balanced (:class:`annotate.chooser.UniformChooser`).
- ``active`` (pairwise studies; their default, :data:`DEFAULT_SAMPLING`):
  :class:`PairwiseSampler` keeps the Gaussian posterior of every object view's method
  scale (:func:`annotate.sampling.update_pairwise`) and hands a rater the test item
  (object view and pair of methods) with the largest expected information gain
  (:func:`annotate.sampling.pair_gain`) among those the rater has not had. Comparisons
  other raters hold right now (live claims) are skipped while any other is left, so raters
  busy at once get different comparisons (the sequential form of ASAP's batch mode: each
  new one is chosen given those in flight); ties go by the rater's own random order.
- ``adaptive`` (binary studies): :class:`BinarySampler` closes an item once its majority
  cannot change (:func:`annotate.sampling.binary_closed`) and sends the freed votes to the
  items whose GVF is most uncertain (:func:`annotate.sampling.gvf_uncertainty`), up to
  ``max_votes_per_item``; ties by fewer votes and claims, then the rater's order.

Both spend at most the uniform design's budget, ``votes_per_item`` x the test items
(standing votes plus others' live claims). Training, gold and repeat items, and the end
of a rater's plan, are :mod:`annotate.chooser`'s, the same for every sampling (a sampler
only chooses among test items). Only test votes move the state.

**Cost per vote.** A sampler is built once per process and refreshed from the store's
append-only ``history`` rows after a watermark (one index range read inside the hand-out
transaction, :meth:`annotate.store.Store.next_item`); a vote is one posterior update, so no
request refits the scale. An undo or a changed vote replays the standing votes (pairwise;
rare), the binary counts are simply corrected. Two processes read the same rows in the same
order, so their posteriors agree.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

import numpy as np

from annotate.sampling import (
    binary_closed,
    gvf_uncertainty,
    pair_gain,
    pair_posterior,
    update_pairwise,
)
from data_schema.errors import InputError
from data_schema.study_manifest import StudyManifest
from data_schema.vocab import ItemKind, Sampling, Side, StudyDesign

__all__ = ["SAMPLINGS", "DEFAULT_SAMPLING", "check_sampling", "study_sampling", "make_sampler",
           "PairwiseSampler", "BinarySampler"]

#: Sampling schemes and the design each needs (None: any design).
SAMPLINGS = {s: s.design for s in Sampling}
#: The scheme a new study of each design gets when none is named. Pairwise: ``active`` since
#: the benchmark (``benchmarks/bench_sampling.py``, 20 seeds: active reaches the full
#: uniform design's scale error with half of its comparisons and ranks at least as well at
#: every budget). Binary stays ``uniform``: ``adaptive`` gives items different numbers of
#: votes, which a study must choose knowingly.
DEFAULT_SAMPLING = {StudyDesign.BINARY: Sampling.UNIFORM, StudyDesign.PAIRWISE: Sampling.ACTIVE}


def check_sampling(sampling: str, *, design: str, votes_per_item: int,
                   max_votes_per_item: int | None) -> int | None:
    """Check ``--sampling`` and ``--max-votes-per-item`` against the design.

    Parameters
    ----------
    sampling : str
        One of :data:`SAMPLINGS`.
    design : str
        ``'binary'`` or ``'pairwise'``.
    votes_per_item : int
        The study's quota per test item.
    max_votes_per_item : int or None
        Adaptive only: the cap per item (None: ``votes_per_item``, curtailed sampling alone;
        a higher cap also spends the freed votes on the most uncertain items).

    Returns
    -------
    int or None
        The cap the manifest records (None unless adaptive).

    Raises
    ------
    InputError
        An unknown scheme, a scheme of the other design, a cap without ``adaptive`` or below
        ``votes_per_item``.

    >>> check_sampling("adaptive", design="binary", votes_per_item=5, max_votes_per_item=None)
    5
    """
    if sampling not in SAMPLINGS:
        raise InputError(param="sampling", expected="one of {'uniform', 'active', 'adaptive'}",
                         got=sampling)
    need = SAMPLINGS[sampling]
    if need is not None and need != design:
        other = Sampling.ACTIVE if design == StudyDesign.PAIRWISE else Sampling.ADAPTIVE
        raise InputError(param="sampling", expected=f"'uniform' or '{other}' with `design` {design} "
                         f"('{sampling}' is for {need} studies)", got=sampling)
    if sampling != Sampling.ADAPTIVE:
        if max_votes_per_item is not None:
            raise InputError(param="max_votes_per_item", expected="no cap unless `sampling` is "
                             "adaptive", got=max_votes_per_item)
        return None
    cap = int(votes_per_item) if max_votes_per_item is None else max_votes_per_item
    if isinstance(cap, bool) or not isinstance(cap, int | np.integer) or cap < votes_per_item:
        raise InputError(param="max_votes_per_item",
                         expected=f"an integer >= `votes_per_item` ({votes_per_item})", got=cap)
    return int(cap)


def study_sampling(manifest: StudyManifest) -> tuple[Sampling, int | None]:
    """A manifest's ``(sampling, max_votes_per_item)``; a study built before ``--sampling``
    (no such keys) is ``('uniform', None)``.

    Parameters
    ----------
    manifest : StudyManifest
        The study's manifest.

    Returns
    -------
    (Sampling, int or None)
    """
    return manifest.sampling, manifest.max_votes_per_item


Reader = Callable[[int], list]


class _Sampler:
    """State shared by both samplers: test keys, standing test votes, the watermark."""

    def __init__(self, study) -> None:
        self.keys = study.keys(ItemKind.TEST)
        self.pos = {k: i for i, k in enumerate(self.keys)}
        self.budget = study.quota * len(self.keys)
        # (rater, key) -> (history id, value): the vote, or what a sampler makes of it
        self.standing: dict[tuple[str, str], tuple[int, float]] = {}
        self.n = np.zeros(len(self.keys), dtype=np.int64)             # standing votes per key
        self.watermark = 0
        self.last_row: tuple | None = None  # the row at the watermark, as read
        self.lock = threading.RLock()

    def refresh(self, rows_after: Reader) -> None:
        """Read the store's history rows after the watermark and apply the test votes.

        The row at the watermark is read again and compared with the one read before: a
        store restored from a backup (or replaced) under a running server no longer has it,
        and the sampler then forgets its state and reads the whole history again, so it
        never keeps votes the store has lost, nor misses rows that took their ids.

        Parameters
        ----------
        rows_after : callable
            ``rows_after(watermark)``: the history rows ``(id, rater, item, action, vote)``
            with a larger id, in id order (:meth:`annotate.store.Store.history_after`).
        """
        with self.lock:
            rows = rows_after(max(self.watermark - 1, 0))
            if self.watermark and (not rows or tuple(rows[0]) != self.last_row):
                self._reset()  # the store was restored or replaced: read it again from the start
                rows = rows_after(0)
            elif self.watermark:
                rows = rows[1:]
            self._prepare(rows)
            for hid, rater, key, action, vote in rows:
                i = self.pos.get(key)
                if i is None or action not in ("vote", "undo"):
                    continue
                old = self.standing.pop((rater, key), None)
                if old is not None:
                    self.n[i] -= 1
                    self._removed(rater, key, i, old[1])
                if action == "vote":
                    value = self._value(rater, key, int(vote))
                    self.standing[(rater, key)] = (int(hid), value)
                    self.n[i] += 1
                    self._added(rater, key, i, value)
            if rows:
                self.watermark, self.last_row = int(rows[-1][0]), tuple(rows[-1])
                self._settle()
            self._prepare([])

    def _prepare(self, rows: list) -> None:
        """Before a batch of history rows is applied (and with none after it)."""

    def _reset(self) -> None:
        """Forget every vote read (the state of a sampler that has read nothing)."""
        self.standing.clear()
        self.n[:] = 0
        self.watermark, self.last_row = 0, None

    def _value(self, rater: str, key: str, vote: int):
        """What the sampler keeps of a standing vote (the vote itself, unless a sampler says
        otherwise): fixed when the vote is read, so no per-rater state is kept beside it."""
        return vote

    def _removed(self, rater, key, i, vote) -> None:
        raise NotImplementedError

    def _added(self, rater, key, i, vote) -> None:
        raise NotImplementedError

    def _settle(self) -> None:
        """After a batch of rows (a sampler that must replay does it here)."""

    def _claims(self, loads: dict[str, int]) -> np.ndarray:
        """Others' live claims per test key: the store's loads less the standing votes."""
        got = np.array([loads.get(k, 0) for k in self.keys], dtype=np.int64)
        return np.maximum(got - self.n, 0)

    def pick(self, open_keys: list[str], loads: dict[str, int]) -> str | None:
        """The test item a rater gets next (see the module docstring).

        Parameters
        ----------
        open_keys : list of str
            The test keys the rater has not had, in the rater's own order.
        loads : dict
            Test key -> standing votes plus other raters' live claims.

        Returns
        -------
        str or None
            None when the budget is spent (claims included) or no candidate is left.
        """
        with self.lock:
            claims = self._claims(loads)
            if int(self.n.sum() + claims.sum()) >= self.budget or not open_keys:
                return None
            idx = np.array([self.pos[k] for k in open_keys], dtype=np.int64)
            best = self._best(idx, claims)
            return None if best is None else self.keys[best]

    def room(self, open_keys: list[str], loads: dict[str, int]) -> int:
        """How many of ``open_keys`` one rater may still be given: those the sampler would
        hand out, at most the budget left (a rater's progress total).

        Parameters
        ----------
        open_keys : list of str
            The test keys the rater has not had.
        loads : dict
            Test key -> standing votes plus other raters' live claims.

        Returns
        -------
        int
        """
        with self.lock:
            claims = self._claims(loads)
            left = int(self.budget - self.n.sum() - claims.sum())
            if left <= 0 or not open_keys:
                return 0
            idx = np.array([self.pos[k] for k in open_keys], dtype=np.int64)
            return min(left, int(self._open(idx, claims).sum()))

    def votes_left(self, loads: dict[str, int]) -> int:
        """Test votes the sampler still hands out: the budget left (claims included), at
        most what the open items can take (adaptive: up to ``max_votes_per_item`` each).

        Parameters
        ----------
        loads : dict
            Test key -> standing votes plus live claims.

        Returns
        -------
        int
        """
        with self.lock:
            claims = self._claims(loads)
            left = max(int(self.budget - self.n.sum() - claims.sum()), 0)
            return min(left, self._item_room(claims))

    def _item_room(self, claims: np.ndarray) -> int:
        """Votes the open test items can take in all (no per-item cap: the budget)."""
        return int(self.budget)

    def _open(self, idx: np.ndarray, claims: np.ndarray) -> np.ndarray:
        """Which of the test items ``idx`` may still get a vote (all, unless a sampler closes some)."""
        return np.ones(len(idx), dtype=bool)

    def _best(self, idx: np.ndarray, claims: np.ndarray) -> int | None:
        raise NotImplementedError


class PairwiseSampler(_Sampler):
    """Active pairwise sampling for one process (module docstring).

    Parameters
    ----------
    study : annotate.study.Study
        A pairwise study; its test items' ``pair_id`` (object view) and methods index the
        posterior, the raters' plans give the side A was shown on.
    """

    def __init__(self, study) -> None:
        super().__init__(study)
        tests = study.items.loc[self.keys]
        methods = list(study.manifest.methods)
        views = list(dict.fromkeys(tests["pair_id"]))
        m = len(methods)
        a = tests["method_a"].map(methods.index).to_numpy()
        b = tests["method_b"].map(methods.index).to_numpy()
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        pair = lo * m - lo * (lo + 1) // 2 + (hi - lo - 1)    # triu_indices(m, 1) order
        self.view = tests["pair_id"].map({v: i for i, v in enumerate(views)}).to_numpy()
        self.a, self.b = a, b
        self.flat = self.view * (m * (m - 1) // 2) + pair
        self.shape = (len(views), m)
        self.post = pair_posterior(*self.shape)
        self._plan = study.plan_for
        self._batch_sides: dict[tuple[str, str], str] = {}
        self._gain: np.ndarray | None = None
        self._replay = False

    def _prepare(self, rows: list) -> None:
        """The side A was shown on for each vote of the batch: each rater's plan read once
        per batch (through the study's bounded plan cache), only the sides the batch needs
        kept, and those dropped after it (before, a dict of every rater's sides, kept for
        good, grew by 0.54 MB a rater in each worker)."""
        need: dict[str, set[str]] = {}
        for _hid, rater, key, action, vote in rows:
            if action == "vote" and vote and key in self.pos:
                need.setdefault(rater, set()).add(key)
        batch = {}
        for rater, keys in need.items():
            sides = self._plan(rater, register=False)["sides"]
            batch.update({(rater, k): sides[k] for k in keys})
        self._batch_sides = batch

    def _value(self, rater: str, key: str, vote: int) -> float:
        """The vote in A/B terms: 1 A closer, 0 B closer, 0.5 can't tell."""
        if vote == 0:
            return 0.5
        return 1.0 if (vote == 1) == (self._batch_sides[(rater, key)] == Side.LEFT) else 0.0

    def _added(self, rater, key, i, score) -> None:
        if not self._replay:
            self.post = update_pairwise(self.post, int(self.view[i]), int(self.a[i]), int(self.b[i]),
                                        score)
        self._gain = None

    def _removed(self, rater, key, i, vote) -> None:
        self._replay = True  # assumed density filtering cannot take a vote out: replay

    def _reset(self) -> None:
        super()._reset()
        self.post, self._gain, self._replay = pair_posterior(*self.shape), None, False

    def _settle(self) -> None:
        if not self._replay:
            return
        self.post = pair_posterior(*self.shape)
        for (_rater, key), (_hid, score) in sorted(self.standing.items(), key=lambda kv: kv[1][0]):
            i = self.pos[key]
            self.post = update_pairwise(self.post, int(self.view[i]), int(self.a[i]), int(self.b[i]),
                                        score)
        self._replay, self._gain = False, None

    def gains(self) -> np.ndarray:
        """Expected information gain (nats) of one more vote on each test key, in
        ``study.keys('test')`` order.

        Returns
        -------
        (T,) float64
        """
        with self.lock:
            if self._gain is None:
                self._gain = pair_gain(self.post).ravel()[self.flat]
            return self._gain

    def _best(self, idx, claims):
        g = self.gains()[idx]
        free = claims[idx] == 0
        if free.any():  # comparisons in flight only when nothing else is left
            g = np.where(free, g, -np.inf)
        return int(idx[int(np.argmax(g))])


class BinarySampler(_Sampler):
    """Adaptive (curtailed) binary sampling for one process (module docstring).

    Parameters
    ----------
    study : annotate.study.Study
        A binary study.
    max_votes_per_item : int
        The most votes one test item may get.
    """

    def __init__(self, study, max_votes_per_item: int) -> None:
        super().__init__(study)
        self.max_votes = int(max_votes_per_item)
        self.quota = study.quota
        self.good = np.zeros(len(self.keys), dtype=np.int64)

    def _added(self, rater, key, i, vote) -> None:
        self.good[i] += int(vote == 1)

    def _removed(self, rater, key, i, vote) -> None:
        self.good[i] -= int(vote == 1)

    def _reset(self) -> None:
        super()._reset()
        self.good[:] = 0

    def _open(self, idx, claims):
        good, n = self.good[idx], self.n[idx]
        return ~binary_closed(good, n - good, votes_per_item=self.quota,
                              max_votes_per_item=self.max_votes) & (n + claims[idx] < self.max_votes)

    def _item_room(self, claims):
        idx = np.arange(len(self.keys), dtype=np.int64)
        room = np.maximum(self.max_votes - self.n - claims, 0)
        return int(room[self._open(idx, claims)].sum())

    def _best(self, idx, claims):
        good, n = self.good[idx], self.n[idx]
        bad, held = n - good, n + claims[idx]
        ok = self._open(idx, claims)
        if not ok.any():
            return None
        u = gvf_uncertainty(good, bad)
        rank = np.arange(len(idx))  # the rater's order
        order = np.lexsort((rank[ok], held[ok], -u[ok]))
        return int(idx[ok][order[0]])


def make_sampler(study) -> _Sampler | None:
    """The study's sampler, or None for a uniform study.

    Parameters
    ----------
    study : annotate.study.Study
        The loaded study.

    Returns
    -------
    PairwiseSampler, BinarySampler or None
    """
    sampling, cap = study_sampling(study.manifest)
    if sampling == Sampling.ACTIVE:
        return PairwiseSampler(study)
    if sampling == Sampling.ADAPTIVE:
        return BinarySampler(study, cap if cap is not None else 2 * study.quota)
    return None
