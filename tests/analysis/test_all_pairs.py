"""``analyze --pairs``: every metric against a proxy over all pairs, streamed clip by clip from
partitioned datasets; checked against SciPy on the same rows joined by pandas."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats as st

from analysis.all_pairs import read_all_pairs, run_pairs_analysis
from analysis.cli import main
from data_schema.datasets import DatasetWriter
from data_schema.tables import PAIRS_COLUMNS, pair_id


def _pairs(rng, n_clips=3, per_clip=40):
    rows = []
    for c in range(n_clips):
        for i in range(per_clip):
            off = float(rng.choice([-2.0, -1.0, 1.0, 2.0]))
            tr, t = f"t{i % 7}", 100 * (i // 7)
            rows.append({"pair_id": pair_id(f"c{c}", "front", tr, t, off), "clip_id": f"c{c}",
                         "camera": "front", "track_id": tr, "label_class": ["car", "pedestrian"][i % 2],
                         "timestamp_us": t, "y_offset_m": off, "gt_path": "g.png", "render_path": "r.png",
                         **dict.fromkeys(PAIRS_COLUMNS[9:], 0), "lighting": ["day", "night", "day"][c],
                         "scene_root": "/x"})
    df = pd.DataFrame(rows)
    q = rng.random(len(df))
    df["clip_drop"] = q + rng.normal(0, 0.2, len(df))
    df["psnr"] = -q + rng.normal(0, 0.3, len(df))
    df["ssim"] = -q * 0.1 + rng.normal(0, 0.1, len(df))
    return df


@pytest.fixture()
def data(tmp_path):
    rng = np.random.default_rng(3)
    full = _pairs(rng)
    with DatasetWriter(tmp_path / "pairs") as w:
        for clip, g in full.groupby("clip_id"):
            w.write(clip, g[list(PAIRS_COLUMNS) + ["lighting", "scene_root"]])
    with DatasetWriter(tmp_path / "metrics") as w:
        for clip, g in full.groupby("clip_id"):
            g = g[["pair_id", "psnr", "ssim"]]
            if clip == "c1":  # another order and one pair missing: the hash-join path
                g = g.sample(frac=1.0, random_state=0).iloc[1:]
            w.write(clip, g)
    full[["pair_id", "clip_drop"]].to_csv(tmp_path / "proxy.csv", index=False)  # a file, no clip_id
    kept = set(pd.read_parquet(tmp_path / "metrics" / "clip_id=c1").pair_id)
    full.loc[(full.clip_id == "c1") & ~full.pair_id.isin(kept), ["psnr", "ssim"]] = np.nan
    return tmp_path, full


def test_items_equal_a_pandas_join(data):
    d, full = data
    items, clusters, unknown = read_all_pairs(d / "pairs", metrics_paths=[d / "metrics", d / "proxy.csv"],
                                              progress=False)
    assert len(items) == len(full) and unknown == {str(d / "metrics"): 0, str(d / "proxy.csv"): 0}
    full = full.sort_values(["clip_id", "pair_id"], kind="stable")  # the canonical order (FORMATS §6)
    for c in ("psnr", "ssim", "clip_drop", "y_offset_m"):
        np.testing.assert_array_equal(items[c].to_numpy(), full[c].to_numpy())
    for c in ("clip_id", "label_class", "lighting"):
        assert items[c].astype(str).tolist() == full[c].tolist()
    # clusters are (clip, track): 3 clips x 7 tracks
    assert clusters.max() + 1 == 21 and len(set(zip(full.clip_id, full.track_id, clusters, strict=True))) == 21


def test_summary_and_breakdowns_match_scipy(data):
    d, full = data
    a = run_pairs_analysis(d / "pairs", metrics_paths=[d / "metrics", d / "proxy.csv"],
                           target="clip_drop", n_boot=0, progress=False)
    assert a.metrics == ["psnr", "ssim"] and a.attributes == ["lighting"] and a.counts["clips"] == 3
    for m in a.metrics:
        ok = full[m].notna()
        row = a.summary.set_index("metric").loc[m]
        # expected values: scipy.stats on the pandas-joined rows
        assert row["plcc"] == pytest.approx(abs(st.pearsonr(full[m][ok], full.clip_drop[ok])[0]), abs=1e-12)
        assert row["srcc"] == pytest.approx(abs(st.spearmanr(full[m][ok], full.clip_drop[ok])[0]), abs=1e-12)
        assert row["n"] == ok.sum()
        night = (full.lighting == "night") & ok
        cat = a.categories.set_index(["breakdown", "group", "metric"]).loc[("lighting", "night", m)]
        assert cat["n"] == night.sum() and cat["k"] == 1
        assert cat["srcc"] == pytest.approx(abs(st.spearmanr(full[m][night], full.clip_drop[night])[0]))
    tent = a.by_offset[a.by_offset.column == "clip_drop"].set_index("y_offset_m")["mean"]
    pd.testing.assert_series_equal(tent, full.groupby("y_offset_m").clip_drop.mean(), check_names=False)


def test_cli_report_and_errors(data, capsys):
    d, full = data
    out = d / "report"
    rc = main(["--pairs", str(d / "pairs"), "--metrics-table", str(d / "metrics"), "--metrics-table", str(d / "proxy.csv"),
               "--target", "clip_drop", "--bootstrap", "50", "--out", str(out), "--quiet"])
    assert rc == 0, capsys.readouterr().err
    assert (out / "report.html").is_file() and (out / "tent.png").is_file()
    assert not (out / "items.csv").exists() and "Raters" not in (out / "report.html").read_text()
    s = pd.read_csv(out / "summary.csv")
    assert s.srcc_ci_lo.notna().all()  # the cluster bootstrap ran over (clip, track)
    capsys.readouterr()
    # a single table without clip_id cannot be streamed by clip
    full.drop(columns="clip_id").to_parquet(d / "flat.parquet")
    for args, msg in [
        (["--pairs", str(d / "flat.parquet"), "--target", "clip_drop"], "clip_id"),
        (["--pairs", str(d / "pairs"), "--metrics-table", str(d / "metrics")], "--target"),
        ([str(d / "proxy.csv"), "--pairs", str(d / "pairs"), "--target", "x"], "both"),
        (["--pairs", str(d / "pairs"), "--metrics-table", str(d / "metrics"), "--metrics-table", str(d / "metrics"),
          "--target", "psnr"], "each metric column in one input"),
    ]:
        assert main(args + ["--out", str(d / "r2"), "--quiet"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and msg in err[0] and "Traceback" not in err[0]
        assert not (d / "r2").exists()


@pytest.mark.parametrize("extra", [["--no-screen"], ["--exclude-raters", "ann"], ["--aggregate", "glad"],
                                   ["--screen"]])
def test_rater_options_are_refused_with_pairs(data, capsys, extra):
    """Issue 29: an option that does not apply to --pairs (no votes) ends the run, never a no-op."""
    d, _ = data
    rc = main(["--pairs", str(d / "pairs"), "--metrics-table", str(d / "metrics"), "--target", "psnr",
               *extra, "--out", str(d / "r3"), "--quiet"])
    err = [line for line in capsys.readouterr().err.strip().splitlines() if not line.startswith("note:")]
    assert rc == 2 and len(err) == 1 and f"expected no {extra[0]} with --pairs" in err[0], err
    assert not (d / "r3").exists()


def test_bootstrap_skip_note_and_timing_beside_metrics(data, monkeypatch):
    import analysis.pipeline as pipeline
    from tests.analysis.synth import make_ratings

    d, full = data
    monkeypatch.setattr(pipeline, "BOOT_CELL_LIMIT", 100)
    pd.DataFrame({"metric": ["clip_drop"], "seconds": [2.0], "pairs": [len(full)]}).to_csv(
        d / "proxy.timing.csv", index=False)
    a = run_pairs_analysis(d / "pairs", metrics_paths=[d / "metrics", d / "proxy.csv"],
                           target="clip_drop", n_boot=10, progress=False)
    assert a.n_boot == 0 and a.notes[-1] == (
        "bootstrap skipped: 120 pairs x 10 replicates is above 1e+02 pair-replicates; "
        "fewer bootstrap replicates give CIs")
    assert a.timing.set_index("metric").loc["clip_drop", "pairs_per_s"] == len(full) / 2.0
    ratings, metrics = make_ratings()
    ratings.to_csv(d / "r.csv", index=False)
    metrics.to_csv(d / "m.csv", index=False)
    a = pipeline.run_analysis(d / "r.csv", metrics_paths=[d / "m.csv"], lower=["blurriness"],
                              n_boot=10, progress=False)
    assert a.n_boot == 0 and a.notes[-1] == (
        "bootstrap skipped: 120 items x 10 replicates is above 1e+02 item-replicates; "
        "fewer bootstrap replicates give CIs")
