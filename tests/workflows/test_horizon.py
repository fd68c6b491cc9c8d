"""Issue 36 acceptance, end to end through the commands a user runs: a synthetic clip rendered by
two methods (artefact scales 0.5 and 1.5, offsets -3..3 m), its NVRQ-CA trust horizon at the
threshold simulated raters give, and the horizon of the clip's true severity at the raters'
own threshold (severity 0.45: annotate.simulate's mean rater threshold).

The clip also has a third method, ``perfect`` (scale 0: severity 0.001, no artefact), which
the study does not show (its pairs are left out of ``annotate build``, so the votes and the
threshold are those of the two-method clip). It measures what NVRQ-CA sees off the path when
nothing is wrong with the render: the change of viewpoint against the recorded GT crop.

What the clip shows (640x360, 1 s at 5 fps, seed 0): see the comments at the asserts."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

import nvrq
from analysis.cli import main as analyze_main
from annotate.cli import main as annotate_main
from tests.workflows.two_methods import ok as _ok
from tests.workflows.two_methods import scored_clip

pytestmark = pytest.mark.slow

#: the clip's methods: the two of the other workflow tests and a render with no artefact
METHODS = "sharp:0.5,blurry:1.5,perfect:0"
#: the methods the study shows (and the raters rate): perfect is measured, never rated
RATED = ("sharp", "blurry")
#: annotate.simulate: rater thresholds theta ~ N(0.45, 0.08) on severity, so the raters'
#: population P(good | severity) is 0.5 at 0.45 (the normal is symmetric around it)
TRUE_SEVERITY_THRESHOLD = 0.45
GRID_STEP = 1.0


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    d = tmp_path_factory.mktemp("horizon")
    scored_clip(d, offsets="-3,-2,-1,0,1,2,3", metrics="nvrq_ca", methods=METHODS)
    pairs = pd.read_csv(d / "pairs.csv", dtype={"track_id": str, "camera": str})
    deg = pd.read_csv(d / "scene" / "degradation.csv", dtype={"track_id": str, "camera": str})
    keys = ["camera", "timestamp_us", "track_id", "method", "y_offset_m"]
    sev = pairs.merge(deg[keys + ["severity"]], on=keys, how="left")
    assert sev["severity"].notna().all()
    sev[["pair_id", "severity"]].to_csv(d / "severity.csv", index=False)
    pairs[pairs["method"].isin(RATED)].to_csv(d / "pairs_rated.csv", index=False)
    return d


def _horizon(clip, name, *argv):
    _ok(analyze_main(["--pairs", str(clip / "pairs.csv"), *argv, "--horizon", "--bootstrap", "200",
                      "--quiet", "--out", str(clip / name)]))
    return pd.read_csv(clip / name / "horizon.csv", keep_default_na=False, na_values=[""])


def _human_threshold(clip) -> dict:
    study, votes = clip / "study", clip / "votes.csv"
    if not (clip / "human" / "horizon.json").is_file():
        _ok(annotate_main(["build", str(study), "--pairs", str(clip / "pairs_rated.csv"), "--metrics-table",
                           str(clip / "metrics.csv"), "--tracks", "12", "--frames-per-track", "3",
                           "--seed", "0", "--quiet"]))
        _ok(annotate_main(["simulate", str(study), "--raters", "6", "--seed", "0"]))
        _ok(annotate_main(["export", str(study), "--out", str(votes)]))
        _ok(analyze_main([str(votes), "--metrics-table", str(clip / "metrics.csv"), "--horizon",
                          "--bootstrap", "200", "--quiet", "--out", str(clip / "human")]))
    return json.loads((clip / "human" / "horizon.json").read_text())


def test_human_threshold_is_the_direct_logistic_fit(clip):
    from scipy.optimize import minimize

    doc = _human_threshold(clip)
    th = doc["threshold"]
    assert th["source"].startswith("people: P(good) = 0.5") and th["ci_lo"] <= th["value"] <= th["ci_hi"]
    v = pd.read_csv(clip / "votes.csv")
    raters = pd.read_csv(clip / "human" / "raters.csv")
    v = v[(v["kind"] == "test") & v["rater_id"].isin(raters.loc[~raters["excluded"], "rater_id"])]
    m = pd.read_csv(clip / "metrics.csv").set_index("pair_id")[doc["metric"]]
    x, y = m.loc[v["item_id"]].to_numpy(float), v["vote"].to_numpy(float)
    ok = np.isfinite(x)
    nll = lambda p: float(np.sum(np.logaddexp(0.0, p[0] + p[1] * x[ok]) - y[ok] * (p[0] + p[1] * x[ok])))  # noqa: E731
    best = minimize(nll, [0.0, 0.0], method="BFGS", options={"gtol": 1e-10})
    assert th["value"] == pytest.approx(-best.x[0] / best.x[1], abs=1e-6)


def test_sharp_goes_at_least_as_far_as_blurry_and_agrees_with_the_true_severity(clip):
    doc = _human_threshold(clip)
    nv = _horizon(clip, "nvrq_ca", "--metrics-table", str(clip / "metrics.csv"), "--threshold",
                  repr(doc["threshold"]["value"]))
    sev = _horizon(clip, "severity", "--metrics-table", str(clip / "severity.csv"), "--metric", "severity",
                   "--lower-better", "severity", "--threshold", str(TRUE_SEVERITY_THRESHOLD))
    h = nv.set_index(["label_class", "axis", "direction", "method"])["horizon"].fillna(-1.0).unstack("method")
    tracks = nv.groupby("label_class")["n_tracks"].max()
    big = tracks[tracks >= 5].index
    assert len(big) >= 1
    rows = h[h.index.get_level_values("label_class").isin(big)]
    assert (rows["sharp"] >= rows["blurry"]).all(), rows
    assert (rows["perfect"] >= rows["sharp"]).all(), rows
    # the horizon of the true severity and that of NVRQ-CA at the raters' threshold, automobiles
    # (7 tracks). Measured on this clip (threshold 0.109 [0.063, 0.170]): blurry 0 m by both
    # sources, both directions; sharp: severity beyond the grid (>= 3 m: every sharp car's
    # severity stays below 0.45), NVRQ-CA 1 m left and 1 m right (2 s clip, threshold 0.128:
    # 1 m left, 2 m right). Why: the perfect render (severity 0.001) gets the same NVRQ-CA
    # horizon as sharp, 1 m left and 1 m right (2 s clip: 1 m left, 2 m right; 13% of its cars
    # below the threshold at 2 m left). NVRQ-CA compares the shifted view's crop with the
    # recorded GT crop, so it also scores the change of viewpoint (the car's side comes into
    # view), which the raters, who see severity only, do not count. The issue's "within one
    # grid step of the true severity" thus holds for blurry; for sharp it holds against the
    # viewpoint ceiling min(severity's horizon, the perfect render's NVRQ-CA horizon), and
    # NVRQ-CA never claims more than the truth.
    both = nv.merge(sev, on=["method", "label_class", "axis", "direction"], suffixes=("_nv", "_sev"))
    cars = both[both["label_class"] == "automobile"].set_index(["method", "direction"])
    assert len(cars) == 6
    h_nv, h_sev = cars["horizon_nv"].fillna(-GRID_STEP), cars["horizon_sev"].fillna(-GRID_STEP)
    assert ((h_nv - h_sev).abs()["blurry"] <= GRID_STEP).all(), cars
    assert (h_nv <= h_sev).all(), cars
    assert cars.loc["perfect", "reason_sev"].str.startswith("beyond the grid").all(), cars
    # the perfect render's NVRQ-CA horizon stops short of the grid: the viewpoint ceiling
    assert (h_nv["perfect"] < h_sev["perfect"]).any(), cars
    ceiling = np.minimum(h_sev, h_nv["perfect"].reindex(h_sev.index, level="direction"))
    for method in RATED:
        assert ((h_nv[method] - ceiling[method]).abs() <= GRID_STEP).all(), cars


def test_python_api_gives_the_cli_rows(clip):
    doc = _human_threshold(clip)
    cli = _horizon(clip, "nvrq_ca_api", "--metrics-table", str(clip / "metrics.csv"), "--threshold",
                   repr(doc["threshold"]["value"]))
    cli["reason"] = cli["reason"].fillna("")
    scores = pd.read_csv(clip / "pairs.csv").merge(pd.read_csv(clip / "metrics.csv"), on="pair_id")
    # the file's row order and a shuffled one: the bootstrap draws tracks in sorted order either way
    for rows in (scores, scores.sample(frac=1.0, random_state=1)):
        api = nvrq.trust_horizon(rows, threshold=doc["threshold"]["value"], share=0.9, n_boot=200, seed=0)
        api = api.assign(threshold_source="given (a fixed threshold)")
        pd.testing.assert_frame_equal(api.reset_index(drop=True), cli, check_dtype=False)


def test_timeline_is_shorter_where_the_clip_degrades(clip):
    sev = pd.read_csv(clip / "severity.csv")
    pairs = pd.read_csv(clip / "pairs.csv")
    late = pairs["timestamp_us"].to_numpy() >= 600_000
    # the same clip made to degrade from 0.6 s: its true severity rises by 0.3 off the path
    worse = sev.assign(severity=np.where(late & (pairs["y_offset_m"] != 0), sev["severity"] + 0.3,
                                         sev["severity"]))
    worse.to_csv(clip / "severity_late.csv", index=False)
    for name, table in (("uniform", None), ("late", clip / "severity_late.csv")):
        if table is None:  # a uniform scene: each method's mean severity at each offset, at all times
            table = clip / "severity_uniform.csv"
            mean = sev["severity"].groupby([pairs["method"], pairs["y_offset_m"]]).transform("mean")
            sev.assign(severity=mean).to_csv(table, index=False)
        _ok(analyze_main(["--pairs", str(clip / "pairs.csv"), "--metrics-table", str(table), "--metric",
                          "severity", "--lower-better", "severity", "--threshold", "0.45", "--horizon",
                          "--window-s", "0.4", "--bootstrap", "0", "--quiet", "--out", str(clip / f"tl_{name}")]))
    uniform = pd.read_csv(clip / "tl_uniform" / "horizon_timeline.csv")
    cars = uniform[(uniform["class"] == "automobile") & (uniform["method"] == "sharp")]
    assert cars.groupby("direction")["horizon"].nunique().eq(1).all(), cars
    late_t = pd.read_csv(clip / "tl_late" / "horizon_timeline.csv")
    s = late_t[(late_t["class"] == "automobile") & (late_t["method"] == "sharp")]
    early_h = s[s["t1_us"] <= 400_000].groupby("direction")["horizon"].min()
    late_h = s[s["t0_us"] >= 800_000].groupby("direction")["horizon"].max()
    assert (late_h.fillna(-1) < early_h).all(), s
