"""Probabilistic aggregation of binary votes with Toloka's crowd-kit (``analyze --aggregate``).

``majority``: the item label is ``majority_good`` (GVF >= 0.5, from
:func:`annotate.results.good_vote_fraction`, the one definition) and no model is fitted.
``dawid-skene`` (Dawid & Skene 1979: one 2x2 confusion matrix per rater, EM) and ``glad``
(Whitehill et al. 2009: one skill per rater and one difficulty per item) fit crowd-kit's
models to the kept raters' test votes. The per-item posterior ``p_good = P(good | votes)``
becomes the continuous target and ``model_good = p_good >= 0.5`` the ROC-AUC label; the
rater table gains the model's quality estimates: ``model_sensitivity`` = P(vote good | good)
and ``model_specificity`` = P(vote bad | bad) for Dawid-Skene, ``model_skill`` (GLAD's alpha)
for GLAD; ``mace`` (Hovy et al. 2013: each rater knows or spams) gives
``model_competence`` = P(not spamming). crowd-kit is imported only when a model is fitted (about 1.5 s of imports).

>>> import pandas as pd
>>> v = pd.DataFrame({"item_id": ["a", "a", "a", "b", "b", "b"], "rater_id": list("xyzxyz"),
...                   "vote": [1, 1, 0, 0, 0, 1]})
>>> items, raters = aggregate(v, method="majority")
>>> items["p_good"].tolist()
[1.0, 0.0]
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd

from analysis.common.choices import METHODS  # one definition of analyze's choices
from annotate.results import good_vote_fraction
from data_schema.errors import check_choice

__all__ = ["METHODS", "aggregate"]



def _answers(test_votes: pd.DataFrame) -> pd.DataFrame:
    return pd.DataFrame({
        "task": test_votes["item_id"].astype(str).to_numpy(),
        "worker": test_votes["rater_id"].astype(str).to_numpy(),
        "label": test_votes["vote"].astype(int).to_numpy(),
    })


def _p_good(probas: pd.DataFrame, tasks) -> np.ndarray:
    col = 1 if 1 in probas.columns else None
    p = probas[col] if col is not None else pd.Series(0.0, index=probas.index)
    return p.reindex(tasks).to_numpy(np.float64)


def _dawid_skene(answers, *, seed):
    from crowdkit.aggregation import DawidSkene

    np.random.seed(seed)  # crowd-kit draws from the global generator
    model = DawidSkene(n_iter=100, tol=1e-6).fit(answers)
    err = model.errors_  # rows (worker, observed label), columns true label
    workers = err.index.get_level_values(0).unique()

    def cell(obs, true):
        if obs not in err.index.get_level_values(1) or true not in err.columns:
            return np.full(len(workers), np.nan)
        return np.array([err.loc[(w, obs), true] for w in workers])

    skills = pd.DataFrame({"rater_id": workers.astype(str), "model_sensitivity": cell(1, 1),
                           "model_specificity": cell(0, 0)})
    return model.probas_, skills


def _glad(answers, *, seed):
    from crowdkit.aggregation import GLAD

    np.random.seed(seed)
    model = GLAD(n_iter=100, tol=1e-5, silent=True).fit(answers)
    alphas = model.alphas_
    skills = pd.DataFrame({"rater_id": alphas.index.astype(str),
                           "model_skill": alphas.to_numpy(np.float64)})
    return model.probas_, skills


def _mace(answers, *, seed):
    from crowdkit.aggregation import MACE

    # 3 EM restarts, not crowd-kit's 10: each restart costs about 2 s of pandas overhead
    model = MACE(n_restarts=3, n_iter=50, random_state=seed).fit(answers)
    names = pd.factorize(answers["worker"])[1]  # crowd-kit's worker order
    # spamming_[:, 1]: posterior that the rater answers the true label (does not spam)
    skills = pd.DataFrame({"rater_id": names.astype(str),
                           "model_competence": model.spamming_[:, 1]})
    return model.probas_, skills


def aggregate(test_votes: pd.DataFrame, *, method: str, seed: int = 0):
    """Per-item ``p_good`` and per-rater model quality from test votes (module docstring).

    Parameters
    ----------
    test_votes : pandas.DataFrame
        One row per test vote: ``item_id, rater_id, vote`` (1 good, 0 bad).
    method : {'majority', 'dawid-skene', 'glad', 'mace'}
        The aggregation (:data:`METHODS`).
    seed : int
        Seeds the EM restarts of ``mace``.

    Returns
    -------
    items : pandas.DataFrame
        ``item_id, p_good, model_good`` in first-seen order.
    raters : pandas.DataFrame
        ``rater_id`` and the model's columns (no rows for ``majority``).

    Raises
    ------
    InputError
        ``method`` is not one of :data:`METHODS`.
    """
    check_choice("method", method, METHODS)
    item_ids = test_votes["item_id"].astype(str)
    tasks = pd.unique(item_ids)
    if method == "majority":  # first-seen order, as tasks
        p = good_vote_fraction(item_ids, test_votes["vote"])["majority_good"].to_numpy(np.float64)
        skills = pd.DataFrame({"rater_id": pd.Series(dtype=str)})
    else:
        fit = {"dawid-skene": _dawid_skene, "glad": _glad, "mace": _mace}[method]
        with warnings.catch_warnings():  # crowd-kit's own pandas deprecation warnings
            warnings.filterwarnings("ignore", module=r"crowdkit\.")
            probas, skills = fit(_answers(test_votes), seed=seed)
        p = _p_good(probas, tasks)
    items = pd.DataFrame({"item_id": tasks, "p_good": p, "model_good": p >= 0.5})
    return items, skills
