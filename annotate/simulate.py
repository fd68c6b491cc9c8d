"""Simulated raters for demos and tests (never mistaken for people: ids are ``sim-*``).

Each item's latent quality is the synthetic scene's ``severity`` (0 perfect .. 1 broken),
read from ``SCENE/degradation.csv`` (columns camera, timestamp_us, track_id, y_offset_m,
severity) of the item's clip. A careful rater ``r`` votes good with probability

    p_good(s) = lapse / 2 + (1 - lapse) * (1 - sigmoid((s - theta_r) / width_r))

with a per-rater threshold ``theta_r ~ N(0.45, 0.08)`` (bias), width ``width_r ~ U(0.04,
0.12)`` (noise) and lapse rate 0.02. The last rater is careless: good with probability 0.5
whatever it sees. Gold items have severity 0 (GT/GT) or 1 (broken). Votes go through the
same store and assignment as the app's, item by item, in each rater's own order.

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

from annotate.store import Store, utc_iso
from data_schema.errors import InputError
from data_schema.perturbation import labels, perturbation_array
from data_schema.raters import SIM_PREFIX

__all__ = ["p_good", "item_severity", "simulate"]

_JOIN = ["camera", "timestamp_us", "track_id", "y_offset_m"]


def p_good(severity, *, theta: float, width: float, lapse: float):
    """Probability of a "good" vote at ``severity`` (array or scalar)."""
    s = np.asarray(severity, dtype=float)
    return lapse / 2 + (1 - lapse) * (1.0 - 1.0 / (1.0 + np.exp(-(s - theta) / width)))


def item_severity(study) -> pd.Series:
    """Severity per item key: joined from each clip's degradation.csv; gold: 0 or 1."""
    items = study.items
    parts = []
    for clip, root in study.manifest["scene_roots"].items():
        path = Path(root) / "degradation.csv"
        if not path.is_file():
            raise InputError(path, None, "a degradation.csv (written by 'nvrq synth') to simulate raters",
                             "no such file")
        deg = pd.read_csv(path, dtype={"camera": str, "track_id": str})
        missing = [c for c in (*_JOIN, "severity") if c not in deg.columns]
        if missing:
            raise InputError(path, f"column {missing[0]!r}", "columns " + ", ".join((*_JOIN, "severity")),
                             ", ".join(deg.columns))
        # joined on the view label (0.01 m / deg, as pair_id); old files: lateral views
        deg = deg.assign(_cm=labels(perturbation_array(deg)), clip_id=str(clip))
        parts.append(deg.drop(columns=["y_offset_m"]).drop_duplicates(["clip_id", *_JOIN[:3], "_cm"]))
    deg = pd.concat(parts, ignore_index=True)
    it = items.assign(_cm=labels(perturbation_array(items)))
    merged = it.merge(deg[["clip_id", "camera", "timestamp_us", "track_id", "_cm", "severity"]],
                      on=["clip_id", "camera", "timestamp_us", "track_id", "_cm"], how="left")
    sev = pd.Series(merged["severity"].to_numpy(dtype=float), index=items.index)
    gold = items["kind"] == "gold"
    sev[gold] = np.where(items.loc[gold, "item_id"].str.startswith("gold-good:"), 0.0, 1.0)
    lost = sev.index[sev.isna()]
    if len(lost):
        raise InputError("degradation.csv", lost[0], "a severity for every study item", "none")
    return sev


def simulate(study, *, raters: int = 5, seed: int = 0, progress: bool = True) -> pd.DataFrame:
    """Let ``raters`` simulated raters (the last careless) rate the study; returns their params."""
    if raters < 1:
        raise InputError("raters", None, "an integer >= 1", raters)


    sev = item_severity(study)
    # the same store file and code path; NORMAL sync: simulated votes need not survive a power cut
    study = dataclasses.replace(study, store=Store(study.store.path, study.store.study,
                                                   synchronous="NORMAL"))
    rng = np.random.default_rng(seed)
    params = []
    for i in range(raters):
        careless = raters > 1 and i == raters - 1
        params.append({"rater_id": f"{SIM_PREFIX}{'careless' if careless else i + 1}",
                       "careless": careless, "theta": float(rng.normal(0.45, 0.08)),
                       "width": float(rng.uniform(0.04, 0.12)), "lapse": 0.02})
    active = list(range(raters))
    # A simulated clock (from now, advancing by each response time) stamps the votes, so the
    # export's order -- by vote time -- and everything computed from it repeat run to run.
    clock = datetime.now(timezone.utc)
    bar = tqdm(desc="simulated votes", unit="vote", disable=not progress)
    while active:  # round-robin, one vote each, so balanced assignment is exercised
        for i in list(active):
            par = params[i]
            key = study.next_item(par["rater_id"])
            if key is None:
                active.remove(i)
                continue
            pg = 0.5 if par["careless"] else float(p_good(sev[key], theta=par["theta"],
                                                          width=par["width"], lapse=par["lapse"]))
            vote = int(rng.random() < pg)  # drawn before the response time, as ever
            response_ms = int(rng.lognormal(np.log(900), 0.4))
            clock += timedelta(milliseconds=response_ms)
            study.store.record_vote(par["rater_id"], key, vote, response_ms=response_ms,
                                    voted_at=utc_iso(clock))
            bar.update()
    bar.close()
    return pd.DataFrame(params)
