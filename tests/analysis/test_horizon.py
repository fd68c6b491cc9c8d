"""The trust horizon (issue 36): nvrq.horizon on hand-made tables whose answer is known, the
human threshold against SciPy, its bootstrap coverage over simulated raters, and the
``analyze --horizon`` outputs on a small table."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from scipy.optimize import minimize

import nvrq
from analysis.cli import main as analyze_main
from analysis.stats.horizon_fit import fit_logistic, vote_threshold
from annotate.simulate import p_good
from nvrq.horizon import (
    HORIZON_COLUMNS,
    TIMELINE_COLUMNS,
    Threshold,
    horizon_timeline,
    trust_horizon,
)

OFFSETS = [-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0]


def step_table(n_tracks=10, *, left=2.0, right=1.0, bad_at=None, frames=1, t_us=0) -> pd.DataFrame:
    """Every object good (score 1) from 0 out to ``left`` m left (y > 0) and ``right`` m right,
    bad (score 0) beyond; ``bad_at``: ``{offset: k}`` makes the first k tracks bad there too."""
    rows = []
    for t in range(n_tracks):
        for f in range(frames):
            for y in OFFSETS:
                good = (0 <= y <= left) or (-right <= y <= 0)
                if bad_at and y in bad_at and t < bad_at[y]:
                    good = False
                rows.append({"clip_id": "c", "camera": "front", "track_id": f"t{t:02d}",
                             "label_class": "automobile", "timestamp_us": t_us + f * 100_000,
                             "y_offset_m": y, "score": float(good)})
    return pd.DataFrame(rows)


def test_a_known_step_gives_exactly_its_horizons():
    # every object good to 2 m left and 1 m right, then bad (issue 36 acceptance)
    h = trust_horizon(step_table(), threshold=0.5, metric="score", share=0.9, n_boot=0)
    assert list(h.columns) == HORIZON_COLUMNS
    got = h.set_index("direction")
    assert got.loc["left", "horizon"] == 2.0 and got.loc["right", "horizon"] == 1.0
    # linear interpolation of share 1 -> 0 between the last good and the first bad offset: d + 0.1
    assert got.loc["left", "crossing"] == pytest.approx(2.1)
    assert got.loc["right", "crossing"] == pytest.approx(1.1)
    assert (got["n_tracks"] == 10).all() and (got["reason"] == "").all()


def test_one_bad_object_in_ten_keeps_the_horizon_at_a_share_of_0_9():
    # 1 of 10 objects bad at 1 m left: share 0.9 >= 0.9, so the horizon is still 2 m
    h = trust_horizon(step_table(bad_at={1.0: 1}), threshold=0.5, metric="score", share=0.9, n_boot=0)
    assert h.set_index("direction").loc["left", "horizon"] == 2.0
    # two of ten (share 0.8) end it at the recorded view
    h2 = trust_horizon(step_table(bad_at={1.0: 2}), threshold=0.5, metric="score", share=0.9, n_boot=0)
    assert h2.set_index("direction").loc["left", "horizon"] == 0.0


def test_beyond_the_grid_and_fails_at_the_recorded_view():
    h = trust_horizon(step_table(left=3.0), threshold=0.5, metric="score", n_boot=0).set_index("direction")
    assert h.loc["left", "horizon"] == 3.0 and h.loc["left", "reason"] == "beyond the grid"
    assert np.isnan(h.loc["left", "crossing"])
    bad = step_table().assign(score=0.0)
    h = trust_horizon(bad, threshold=0.5, metric="score", n_boot=0)
    assert h["horizon"].isna().all() and (h["reason"] == "fails at the recorded view").all()


def test_lower_better_threshold_and_metric_resolution():
    s = step_table().assign(sev=lambda d: 1.0 - d["score"])  # severity: good at or below the threshold
    h = trust_horizon(s, threshold=Threshold("sev", 0.5, good_above=False, source="true severity"),
                      n_boot=0).set_index("direction")
    assert h.loc["left", "horizon"] == 2.0 and h.loc["left", "threshold_source"] == "true severity"
    s = s.rename(columns={"score": "nvrq_ca:efficientnet-lite0"})
    assert (nvrq.trust_horizon(s, threshold=0.5, n_boot=0)["metric"] == "nvrq_ca:efficientnet-lite0").all()


def test_the_interval_is_the_bootstrap_of_duplicated_tracks():
    # the weighted bootstrap equals recomputing the crossing on data where each drawn track is
    # copied as often as it is drawn (the definition of a cluster bootstrap), replicate by replicate
    from nvrq.horizon import _boot_counts

    rng = np.random.default_rng(3)
    s = step_table(n_tracks=8, frames=3)
    s["score"] = np.where(rng.random(len(s)) < 0.15, 1.0 - s["score"], s["score"])  # some noise
    h = trust_horizon(s, threshold=0.5, metric="score", share=0.7, n_boot=40, seed=5).set_index("direction")
    left = s[s["y_offset_m"] >= 0]
    counts = _boot_counts(8, 40, 5)
    crossings = []
    for c in counts:
        parts = [left[left["track_id"] == f"t{t:02d}"] for t in range(8) for _ in range(int(c[t]))]
        d = pd.concat(parts).assign(track_id=lambda x: np.arange(len(x)) // 1000)  # tracks no longer matter
        r = trust_horizon(d, threshold=0.5, metric="score", share=0.7, n_boot=0, min_clusters=2)
        r = r.set_index("direction").loc["left"]
        crossings.append(r["crossing"] if np.isfinite(r["crossing"]) else
                         (3.0 if r["reason"].startswith("beyond the grid") else 0.0))
    lo, hi = np.quantile(crossings, [0.025, 0.975])
    assert h.loc["left", "ci_lo"] == pytest.approx(lo) and h.loc["left", "ci_hi"] == pytest.approx(hi)


def test_too_few_tracks_give_no_interval():
    h = trust_horizon(step_table(n_tracks=3), threshold=0.5, metric="score", n_boot=50)
    assert h["ci_lo"].isna().all()
    assert (h["reason"] == "3 tracks, fewer than the 5 an interval needs").all()


def test_timeline_is_uniform_for_a_uniform_scene_and_shorter_where_it_degrades():
    early = step_table(frames=5)  # 0 .. 0.4 s
    late = step_table(frames=5, t_us=2_000_000)  # the second 2 s window
    uniform = horizon_timeline(pd.concat([early, late]), threshold=Threshold("score", 0.5), n_boot=0)
    assert list(uniform.columns) == TIMELINE_COLUMNS
    assert uniform.groupby("direction")["horizon"].nunique().eq(1).all()
    assert sorted(uniform["t0_us"].unique()) == [0, 2_000_000]
    degraded = step_table(frames=5, t_us=2_000_000, left=1.0)  # made to degrade in the second window
    t = horizon_timeline(pd.concat([early, degraded]), threshold=Threshold("score", 0.5), n_boot=0)
    left = t[t["direction"] == "left"].set_index("t0_us")["horizon"]
    assert left[0] == 2.0 and left[2_000_000] == 1.0
    assert (t["n_objects"] == 5 * 10 * 4).all()  # 5 frames x 10 tracks x 4 offsets (0 counted in both)


def _nll(p, x, y):
    z = p[0] + p[1] * x
    return float(np.sum(np.logaddexp(0.0, z) - y * z))


def test_human_threshold_equals_a_direct_scipy_fit():
    rng = np.random.default_rng(0)
    x = rng.uniform(0, 1, 600)
    y = (rng.random(600) < 1.0 / (1.0 + np.exp(-(4.0 - 9.0 * x)))).astype(float)
    r = vote_threshold(x, y, np.arange(600) % 6, np.arange(600) % 30, good_prob=0.5, n_boot=0)
    best = minimize(_nll, [0.0, 0.0], args=(x, y), method="BFGS", options={"gtol": 1e-12})
    assert r["value"] == pytest.approx(-best.x[0] / best.x[1], abs=1e-6)
    # and at P(good) = 0.7: logit(0.7) = a + b m
    r7 = vote_threshold(x, y, np.arange(600) % 6, np.arange(600) % 30, good_prob=0.7, n_boot=0)
    assert r7["value"] == pytest.approx((np.log(0.7 / 0.3) - best.x[0]) / best.x[1], abs=1e-6)
    a, b = fit_logistic(x, np.zeros_like(x))
    assert np.isnan(a).all() and np.isnan(b).all()  # one outcome only: undefined


def _simulated_votes(seed: int, *, raters=10, tracks=25, per_track=5):
    """Votes as annotate.simulate casts them: per-rater theta ~ N(0.45, 0.08), width
    ~ U(0.04, 0.12), lapse 0.02, on items whose severities cluster by track. By the symmetry of
    theta's normal around 0.45 the population's P(good | severity) is 0.5 at severity 0.45."""
    rng = np.random.default_rng(seed)
    theta, width = rng.normal(0.45, 0.08, raters), rng.uniform(0.04, 0.12, raters)
    sev = np.clip(rng.uniform(0, 0.9, (tracks, 1)) + rng.normal(0, 0.15, (tracks, per_track)), 0, 0.9).ravel()
    track = np.repeat(np.arange(tracks), per_track)
    r = np.repeat(np.arange(raters), len(sev))
    x, t = np.tile(sev, raters), np.tile(track, raters)
    y = (rng.random(len(x)) < p_good(x, theta=theta[r], width=width[r], lapse=0.02)).astype(float)
    return x, y, r, t


def test_the_human_threshold_interval_covers_the_true_value():
    # 50 seeds x 200 replicates: 200 is enough for a 95% percentile interval's ends to move by
    # about 0.005 in severity (a tenth of the half-width), and keeps this test under 30 s.
    # Measured: 48 of 50 seeds covered (96%), 16 s on a loaded 2-core machine.
    hits = []
    for seed in range(50):
        x, y, r, t = _simulated_votes(seed)
        res = vote_threshold(1.0 - x, y, r, t, good_prob=0.5, n_boot=200, seed=seed)  # a higher-better metric
        hits.append(res["ci_lo"] <= 1.0 - 0.45 <= res["ci_hi"])
    assert np.mean(hits) >= 0.9, np.mean(hits)


def _ratings(tmp_path):
    """A ratings table of 6 raters on a step scene and its metrics table (pair_id, score)."""
    s = step_table(n_tracks=8, frames=2)
    s["item_id"] = [f"i{i}" for i in range(len(s))]
    rng = np.random.default_rng(1)
    rows = []
    for rater in range(6):
        p = np.where(s["score"] > 0.5, 0.9, 0.1)
        v = (rng.random(len(s)) < p).astype(int)
        rows.append(s.drop(columns=["score"]).assign(rater_id=f"r{rater}", vote=v, kind="test",
                                                     response_ms=1500, voted_at="2026-01-01T00:00:00Z"))
    votes = pd.concat(rows, ignore_index=True)
    votes.to_csv(tmp_path / "ratings.csv", index=False)
    # the metric: higher is better, the step plus noise
    m = s["score"] + rng.normal(0, 0.2, len(s))
    pd.DataFrame({"pair_id": s["item_id"], "score": m}).to_csv(tmp_path / "metrics.csv", index=False)
    return votes, m


def test_analyze_ratings_horizon_writes_its_files(tmp_path):
    votes, m = _ratings(tmp_path)
    rc = analyze_main([str(tmp_path / "ratings.csv"), "--metrics-table", str(tmp_path / "metrics.csv"),
                       "--higher-better", "score", "--horizon", "--metric", "score", "--bootstrap", "100",
                       "--no-screen", "--quiet", "--out", str(tmp_path / "r")])
    assert rc == 0
    d = tmp_path / "r"
    doc = json.loads((d / "horizon.json").read_text())
    assert doc["schema"] == "nvrq.horizon" and doc["version"] == 1 and doc["metric"] == "score"
    # the threshold is the direct fit of P(good | score) on every vote
    x = m.to_numpy()[pd.Index(votes["item_id"].drop_duplicates()).get_indexer(votes["item_id"])]
    best = minimize(_nll, [0.0, 0.0], args=(x, votes["vote"].to_numpy(float)), method="BFGS",
                    options={"gtol": 1e-12})
    assert doc["threshold"]["value"] == pytest.approx(-best.x[0] / best.x[1], abs=1e-6)
    # by default each view has its own threshold (the pooled one stays as the reference)
    assert doc["threshold"]["source"].startswith("people, per view: P(good) = 0.5 on a monotone")
    assert {r["threshold_kind"] for r in doc["horizons"]} == {"people_view"}
    views = pd.read_csv(d / "horizon_view_thresholds.csv")
    assert len(views) == len(OFFSETS) == len(doc["view_thresholds"]) and views["threshold"].notna().all()
    assert doc["grid"] == {"y": OFFSETS}
    h = pd.read_csv(d / "horizon.csv", keep_default_na=False)
    assert list(h.columns) == HORIZON_COLUMNS and set(h["direction"]) == {"left", "right"}
    assert list(pd.read_csv(d / "horizon_timeline.csv").columns) == TIMELINE_COLUMNS
    html = (d / "report.html").read_text()
    assert "<h2>Trust horizon</h2>" in html and "all: automobile stays good to" in html
    assert (d / "horizon_all.png").is_file() and (d / "horizon_timeline.png").is_file()
    assert "## Trust horizon" in (d / "report.md").read_text()
    assert "Thresholds per view (people, per view" in html
    # --pooled-threshold: the one pooled threshold judges every view
    rc = analyze_main([str(tmp_path / "ratings.csv"), "--metrics-table", str(tmp_path / "metrics.csv"),
                       "--higher-better", "score", "--horizon", "--metric", "score", "--bootstrap", "100",
                       "--pooled-threshold", "--no-screen", "--quiet", "--out", str(tmp_path / "p")])
    pooled = json.loads((tmp_path / "p" / "horizon.json").read_text())
    assert rc == 0 and pooled["threshold"]["source"].startswith("people: P(good) = 0.5")
    assert {r["threshold_kind"] for r in pooled["horizons"]} == {"people_pooled"}
    assert pooled["view_thresholds"] == [] and not (tmp_path / "p" / "horizon_view_thresholds.csv").exists()
    assert pooled["threshold"]["value"] == doc["threshold"]["value"]


def test_the_vote_threshold_gives_no_interval_from_too_few_raters():
    from analysis.stats.bootstrap import MIN_RATERS

    x, y, r, t = _simulated_votes(0, raters=10)
    for raters in (1, 2, MIN_RATERS):
        keep = r < raters
        res = vote_threshold(x[keep], y[keep], r[keep], t[keep], n_boot=100, seed=0)
        assert np.isfinite(res["value"])
        if raters < MIN_RATERS:
            assert np.isnan(res["ci_lo"]) and f"no interval from {raters} rater" in res["reason"]
        else:
            assert res["ci_lo"] <= res["value"] <= res["ci_hi"] and res["reason"] == ""
