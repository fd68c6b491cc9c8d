"""Simulated raters for demos and tests (never mistaken for people: ids are ``sim-*``).

Layer: annotate (rating study).

Binary (good/bad) studies. Each item's latent quality is the synthetic scene's ``severity`` (0 perfect .. 1 broken),
read from ``SCENE/degradation.csv`` (columns camera, timestamp_us, track_id, y_offset_m,
severity; and ``method`` for a scene with methods) of the item's clip. A careful rater ``r`` votes good with probability

    p_good(s) = lapse / 2 + (1 - lapse) * (1 - sigmoid((s - theta_r) / width_r))

with a per-rater threshold ``theta_r ~ N(0.45, 0.08)`` (bias), width ``width_r ~ U(0.04,
0.12)`` (noise) and lapse rate 0.02. The last rater is careless: good with probability 0.5
whatever it sees. Ids are ``sim-1, sim-2, ...`` and ``sim-careless``; a study simulated
again gets new ids (:func:`new_rater_ids`), or a refusal when its test items need fewer votes
than the new raters. Gold items have severity 0 (GT/GT) or 1 (broken). Votes go through the
same store and assignment as the app's, item by item, in each rater's own order.

Pairwise studies (:mod:`annotate.pairwise`). The renders' severities come from
degradation.csv's ``method`` column (the GT crop of a gold item: 0); a careful rater answers
by :func:`p_choice` of ``delta = sev_b - sev_a`` with its own indifference half-width
``tie_r ~ U(0.01, 0.05)``, width ``width_r ~ U(0.04, 0.12)`` and lapse 0.02, and presses the
side its plan shows the chosen render on (1 left, 2 right, 0 can't tell); the careless rater
presses left or right at random.

>>> float(p_good(0.45, theta=0.45, width=0.1, lapse=0.0))
0.5
>>> bool(p_good(1.0, theta=0.45, width=0.05, lapse=0.0) < 1e-4)
True
"""

from __future__ import annotations

import dataclasses
from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from annotate.pairwise import GT_METHOD, METHOD_COLUMN
from annotate.store import Store, utc_iso
from data_schema.errors import InputError
from data_schema.perturbation import labels, perturbation_array
from data_schema.raters import SIM_PREFIX
from data_schema.tables import require_columns
from data_schema.vocab import ItemKind, Side, StudyDesign

__all__ = ["p_good", "p_choice", "item_severity", "pairwise_severity", "new_rater_ids", "simulate"]

_JOIN = ["camera", "timestamp_us", "track_id", "y_offset_m"]


def p_good(severity, *, theta: float, width: float, lapse: float):
    """Probability of a "good" vote at ``severity`` (array or scalar).

    Parameters
    ----------
    severity : float or array
        Latent severity, 0 (perfect) to 1 (broken).
    theta : float
        The rater's threshold (severity of a 50 % vote without lapses).
    width : float
        Logistic scale of the rater's noise.
    lapse : float
        Rate of random votes, in [0, 1].

    Returns
    -------
    float or array
        Probability in [0, 1], shaped as ``severity``.
    """
    s = np.asarray(severity, dtype=float)
    return lapse / 2 + (1 - lapse) * (1.0 - 1.0 / (1.0 + np.exp(-(s - theta) / width)))


def _degradation(study) -> pd.DataFrame:
    """Each clip's degradation.csv: ``clip_id, camera, timestamp_us, track_id, _cm`` (the view
    label), ``method`` when the file has one, and ``severity``; one row per render."""
    parts = []
    for clip, root in study.manifest.scene_roots.items():
        path = Path(root) / "degradation.csv"
        if not path.is_file():
            raise InputError(path, None, "a degradation.csv (written by 'nvrq synth') to simulate raters",
                             "no such file")
        deg = pd.read_csv(path, dtype={"camera": str, "track_id": str, METHOD_COLUMN: str})
        require_columns(deg, (*_JOIN, "severity"), where=path)
        if study.design == StudyDesign.PAIRWISE and METHOD_COLUMN not in deg.columns:
            raise InputError(path, f"column {METHOD_COLUMN!r}", "the method of each render "
                             "(one severity per method) to simulate a pairwise study",
                             "no such column")
        # joined on the view label (0.01 m / deg, as pair_id); old files: lateral views
        deg = deg.assign(_cm=labels(perturbation_array(deg)), clip_id=str(clip))
        keys = ["clip_id", *_JOIN[:3], "_cm", *([METHOD_COLUMN] if METHOD_COLUMN in deg else [])]
        parts.append(deg[[*keys, "severity"]].drop_duplicates(keys))
    return pd.concat(parts, ignore_index=True)


_OBJECT_VIEW = ["clip_id", "camera", "timestamp_us", "track_id", "_cm"]


def _join_severity(items: pd.DataFrame, deg: pd.DataFrame, method: str | None) -> np.ndarray:
    """(N,) severity of each item's render (of the method in column ``method`` when given,
    else of the item's own ``method`` attribute when both tables have one)."""
    it = items.assign(_cm=labels(perturbation_array(items)))
    on = list(_OBJECT_VIEW)
    if method is not None:
        it, on = it.assign(**{METHOD_COLUMN: it[method].astype(str)}), [*on, METHOD_COLUMN]
    elif METHOD_COLUMN in deg.columns and METHOD_COLUMN in it.columns:
        it, on = it.assign(**{METHOD_COLUMN: it[METHOD_COLUMN].astype(str)}), [*on, METHOD_COLUMN]
    else:
        deg = deg.drop_duplicates(on)
    return it[on].merge(deg[[*on, "severity"]], on=on, how="left")["severity"].to_numpy(float)


def _check_found(sev: pd.Series | pd.DataFrame) -> None:
    lost = sev.index[np.asarray(sev.isna()).reshape(len(sev), -1).any(axis=1)]
    if len(lost):
        raise InputError("degradation.csv", lost[0], "a severity for every study item", "none")


def item_severity(study) -> pd.Series:
    """Severity per item key: joined from each clip's degradation.csv; gold: 0 or 1.

    Parameters
    ----------
    study : Study
        An open binary study of synthetic scenes.

    Returns
    -------
    pandas.Series
        Severity in [0, 1] by item key.
    """
    items = study.items
    sev = pd.Series(_join_severity(items, _degradation(study), None), index=items.index)
    gold = items["kind"] == ItemKind.GOLD
    sev[gold] = np.where(items.loc[gold, "item_id"].str.startswith("gold-good:"), 0.0, 1.0)
    _check_found(sev)
    return sev


def pairwise_severity(study) -> pd.DataFrame:
    """Per item key of a pairwise study: ``sev_a, sev_b``, the severities of the renders of
    ``method_a`` and ``method_b`` (degradation.csv with a ``method`` column); the GT crop of
    a gold item (``method_a = gt``) has severity 0.

    Parameters
    ----------
    study : Study
        An open pairwise study of synthetic scenes, whose degradation.csv names each method.

    Returns
    -------
    pandas.DataFrame
        Columns ``sev_a, sev_b`` in [0, 1], indexed by item key.
    """
    items, deg = study.items, _degradation(study)
    gt = items["method_a"] == GT_METHOD
    sev_a = np.where(gt, 0.0, _join_severity(items.assign(method_a=items["method_a"].where(~gt, "")),
                                             deg, "method_a"))
    out = pd.DataFrame({"sev_a": sev_a, "sev_b": _join_severity(items, deg, "method_b")},
                       index=items.index)
    _check_found(out)
    return out


def p_choice(delta, *, tie: float, width: float, lapse: float):
    """``(p_a, p_b, p_tie)`` of a pairwise answer at ``delta = sev_b - sev_a`` (> 0: A is
    less degraded); arrays broadcast.

    The rater prefers A when ``delta`` exceeds its indifference half-width ``tie`` by a
    logistic margin of scale ``width``, B symmetrically, and cannot tell otherwise; a lapse
    (rate ``lapse``) is a uniform answer among the three. ``p_a + p_b <= 1`` because
    ``tie >= 0``.

    Parameters
    ----------
    delta : float or array
        ``sev_b - sev_a``.
    tie : float
        Indifference half-width, >= 0.
    width : float
        Logistic scale.
    lapse : float
        Rate of uniform answers, in [0, 1].

    Returns
    -------
    p_a, p_b, p_tie : float or array
        Shaped as ``delta``; they sum to 1.

    >>> [round(float(p), 3) for p in p_choice(0.0, tie=0.0, width=0.1, lapse=0.0)]
    [0.5, 0.5, 0.0]
    >>> pa, pb, pt = p_choice(0.5, tie=0.02, width=0.05, lapse=0.03)
    >>> round(float(pa), 3), round(float(pb), 3), round(float(pt), 3)
    (0.98, 0.01, 0.01)

    (``p_a = 0.03 / 3 + 0.97 * sigmoid((0.5 - 0.02) / 0.05) = 0.01 + 0.97 * 0.99993``.)
    """
    d = np.asarray(delta, dtype=float)
    pa = 1.0 / (1.0 + np.exp(-(d - tie) / width))
    pb = 1.0 / (1.0 + np.exp(-(-d - tie) / width))
    pa, pb = lapse / 3 + (1 - lapse) * pa, lapse / 3 + (1 - lapse) * pb
    return pa, pb, 1.0 - pa - pb


def new_rater_ids(existing, raters: int) -> list[str]:
    """Ids for ``raters`` more simulated raters beside the ``existing`` rater ids: careful raters
    numbered on from the highest ``sim-N``, the last (with ``raters > 1``) careless:
    ``sim-careless``, else ``sim-careless-2``, ... (a study simulated again gets new raters,
    never the ones that already voted).

    Parameters
    ----------
    existing : iterable of str
        Rater ids already in the study.
    raters : int
        How many new ids.

    Returns
    -------
    list of str

    >>> new_rater_ids([], 3)
    ['sim-1', 'sim-2', 'sim-careless']
    >>> new_rater_ids(["sim-1", "sim-2", "sim-careless", "ann"], 2)
    ['sim-3', 'sim-careless-2']
    """
    taken = set(existing)
    nums = [int(r[len(SIM_PREFIX):]) for r in taken
            if r.startswith(SIM_PREFIX) and r[len(SIM_PREFIX):].isdigit()]
    first = max(nums, default=0) + 1
    careful = raters - 1 if raters > 1 else raters
    ids = [f"{SIM_PREFIX}{first + i}" for i in range(careful)]
    if raters > 1:
        name, k = f"{SIM_PREFIX}careless", 1
        while name in taken:
            k += 1
            name = f"{SIM_PREFIX}careless-{k}"
        ids.append(name)
    return ids


def _check_room(study, raters: int) -> None:
    """Refuse more simulated raters than the test votes the study still takes (uniform: each
    item ``votes_per_item``; active and adaptive: the sampler's budget left, adaptive at most
    ``max_votes_per_item`` on each item it keeps open, :mod:`annotate.chooser`): they would
    vote on nothing but training."""
    chooser = study.chooser
    chooser.refresh(study.store.history_after)
    room = chooser.votes_left(study.store.item_loads(), study.keys(ItemKind.TEST))
    if room < raters:
        sims = sum(r.startswith(SIM_PREFIX) for r in study.store.raters())
        need = (f"at most {room} more rater(s): the test items need {room} more votes"
                if room else "a study whose test items still need votes")
        cap = study.manifest.max_votes_per_item
        per = {"uniform": f"{study.quota} per item",
               "active": f"{study.quota} per item on average",
               "adaptive": f"{study.quota} per item on average, at most {cap}"}[study.sampling]
        raise InputError(param="raters", expected=f"{need} ({per}; {sims} simulated "
                         "raters so far: build a new study, or one with more votes per item, to "
                         "simulate more)", got=raters)


def simulate(study, *, raters: int = 5, seed: int = 0, progress: bool = True) -> pd.DataFrame:
    """Let ``raters`` new simulated raters (the last careless) rate the study; returns their
    parameters and ``test_votes``, the test votes each recorded.

    Rater ids are new (:func:`new_rater_ids`) when the study was simulated before; raises
    :class:`InputError` (``raters``) when the study's test items need fewer votes than
    ``raters`` (a simulated rater would vote on no test item).

    Parameters
    ----------
    study : Study
        An open study of synthetic scenes.
    raters : int, optional
        New simulated raters (the last careless).
    seed : int, optional
        Seed of the raters' parameters and votes.
    progress : bool, optional
        Show a progress bar.

    Returns
    -------
    pandas.DataFrame
        One row per new rater: its parameters and ``test_votes``.

    Raises
    ------
    InputError
        ``raters`` exceeds the votes the test items still need.
    """
    if raters < 1:
        raise InputError(param="raters", expected="an integer >= 1", got=raters)
    _check_room(study, raters)
    pairwise = study.design == StudyDesign.PAIRWISE
    sev = pairwise_severity(study) if pairwise else item_severity(study)
    # the same store file and code path; NORMAL sync: simulated votes need not survive a power cut
    study = dataclasses.replace(study, store=Store(study.store.path, study.store.study,
                                                   synchronous="NORMAL",
                                                   votes=study.store.votes_allowed))
    rng = np.random.default_rng(seed)
    params = []
    for i, rater_id in enumerate(new_rater_ids(study.store.raters(), raters)):
        careless = raters > 1 and i == raters - 1
        par = {"rater_id": rater_id, "careless": careless, "test_votes": 0}
        if pairwise:
            par.update(tie=float(rng.uniform(0.01, 0.05)), width=float(rng.uniform(0.04, 0.12)),
                       lapse=0.02)
        else:
            par.update(theta=float(rng.normal(0.45, 0.08)), width=float(rng.uniform(0.04, 0.12)),
                       lapse=0.02)
        params.append(par)
    active = list(range(raters))
    # A simulated clock (from now, advancing by each response time) stamps the votes, so the
    # export's order -- by vote time -- and everything computed from it repeat run to run. It
    # runs ahead of the wall clock (about 1 s per vote), so at the end every simulated vote is
    # moved back by the lead: the last one lands at the end of the run, none in the future.
    clock = datetime.now(timezone.utc)
    bar = tqdm(desc="simulated votes", unit="vote", disable=not progress)
    while active:  # round-robin, one vote each, so balanced assignment is exercised
        for i in list(active):
            par = params[i]
            key = study.next_item(par["rater_id"])
            if key is None:
                active.remove(i)
                continue
            if pairwise:
                vote = _pairwise_vote(study, par, key, sev, rng)
            else:
                pg = 0.5 if par["careless"] else float(p_good(sev[key], theta=par["theta"],
                                                              width=par["width"], lapse=par["lapse"]))
                vote = int(rng.random() < pg)  # drawn before the response time, as ever
            response_ms = int(rng.lognormal(np.log(900), 0.4))
            clock += timedelta(milliseconds=response_ms)
            study.store.record_vote(par["rater_id"], key, vote, response_ms=response_ms,
                                    voted_at=utc_iso(clock))
            par["test_votes"] += int(study.items.at[key, "kind"] == ItemKind.TEST)
            bar.update()
    bar.close()
    lead = (clock - datetime.now(timezone.utc)).total_seconds()
    if lead > 0:
        study.store.shift_vote_times([p["rater_id"] for p in params], -lead)
    return pd.DataFrame(params)


def _pairwise_vote(study, par: dict, key: str, sev: pd.DataFrame, rng) -> int:
    """The key a simulated rater presses on pairwise item ``key``: 1 left, 2 right, 0 can't
    tell. A careful rater answers by :func:`p_choice` (then pressed on A's side, which its
    plan gives); the careless one presses left or right at random."""
    u = rng.random()
    if par["careless"]:
        return 1 if u < 0.5 else 2
    pa, pb, _ = p_choice(sev.at[key, "sev_b"] - sev.at[key, "sev_a"], tie=par["tie"],
                         width=par["width"], lapse=par["lapse"])
    if u >= pa + pb:
        return 0
    a_left = study.plan_for(par["rater_id"])["sides"][key] == Side.LEFT
    return 1 if (u < pa) == a_left else 2
