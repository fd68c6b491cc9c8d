"""Export (docs/FORMATS.md §5), GVF, Krippendorff's alpha, simulate, and the CLI shell."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from annotate.cli import main
from annotate.commands.serve import serve_command
from annotate.results import gvf_table, nominal_alpha, ratings_table
from annotate.simulate import p_good, simulate
from data_schema.tables import PAIR_META_COLUMNS, RATINGS_COLUMNS


def _vote_all(study, rater, fn):
    while (key := study.next_item(rater)) is not None:
        study.store.record_vote(rater, key, fn(key), response_ms=500)


def test_export_columns_rows_and_metrics(make_study, toy_inputs, tmp_path):
    _scene, pairs = toy_inputs
    p = pd.read_csv(pairs)
    metrics = pd.DataFrame({"pair_id": p["pair_id"], "psnr": np.arange(len(p), dtype=float)})
    metrics.to_csv(tmp_path / "m.csv", index=False)
    s = make_study(metrics_path=tmp_path / "m.csv")
    _vote_all(s, "ann", lambda k: 1)
    s.store.record_vote("ann", s.keys("test")[0], 0)  # changed vote: one row, the last
    out = tmp_path / "ratings.csv"
    assert main(["export", str(s.root), "--out", str(out)]) == 0
    r = pd.read_csv(out)
    assert list(r.columns) == [*RATINGS_COLUMNS, *PAIR_META_COLUMNS, "lighting", "road_type", "psnr"]
    # one row per item ann was shown: every item but the pool's gold not drawn for ann (issue 38 item 31)
    shown = len(s.items) - len(s.keys("gold")) + s.gold_per_rater
    assert len(r) == shown and not r.duplicated(["rater_id", "item_id", "kind"]).any()
    assert r.loc[r["item_id"] == s.keys("test")[0], "vote"].tolist() == [0]
    assert set(r["kind"]) == {"test", "gold", "training", "repeat"}
    assert r["voted_at"].str.match(r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z$").all()
    test = r[r["kind"] == "test"].merge(metrics, left_on="item_id", right_on="pair_id",
                                        suffixes=("", "_m"))
    assert (test["psnr"] == test["psnr_m"]).all()  # metric joined on pair id
    assert r.loc[r["kind"] == "gold", "psnr"].isna().all()


def test_gvf_and_alpha_against_hand_and_krippendorff():
    # hand example: item a: 2 of 3 good -> 2/3; item b: 0 of 2 -> 0
    r = pd.DataFrame({"item_id": ["a", "a", "a", "b", "b", "b"], "rater_id": list("xyzxyz"),
                      "vote": [1, 1, 0, 0, 0, 1], "kind": ["test"] * 5 + ["training"]})
    g = gvf_table(r).set_index("item_id")
    assert g.loc["a", "gvf"] == pytest.approx(2 / 3) and g.loc["b", "gvf"] == 0.0
    assert g.loc["a", "majority_good"] and not g.loc["b", "majority_good"]
    # Krippendorff's nominal alpha worked by hand (coincidence matrix, Krippendorff 2011):
    # rater x: 1,1,0,0; rater y: 1,0,0,0 -> o_01 = o_10 = 1 (item q), n_0 = 5, n_1 = 3, n = 8;
    # D_o = 2/8 = 0.25, D_e = 2*5*3/(8*7) = 30/56, alpha = 1 - D_o/D_e = 0.5333
    r2 = pd.DataFrame({"item_id": list("pqrs") * 2, "rater_id": ["x"] * 4 + ["y"] * 4,
                       "vote": [1, 1, 0, 0, 1, 0, 0, 0], "kind": "test"})
    alpha, _ = nominal_alpha(r2)
    assert alpha == pytest.approx(1 - 0.25 / (30 / 56))
    one = r2[r2["rater_id"] == "x"]
    assert nominal_alpha(one)[0] is None


def test_simulate_follows_severity_and_uses_sim_ids(make_study):
    s = make_study(tracks=4, frames_per_track=6, votes_per_item=6, n_gold=2)
    params = simulate(s, raters=6, seed=1, progress=False)
    assert params["rater_id"].str.startswith("sim-").all() and params["careless"].sum() == 1
    r = ratings_table(s)
    g = gvf_table(r)
    # toy severity = |offset| / 2: offset 0 -> 0 (good), +-1 -> 0.5 (around the threshold 0.45)
    assert g.loc[g["y_offset_m"] == 0, "gvf"].mean() > g.loc[g["y_offset_m"] != 0, "gvf"].mean() + 0.2
    assert (g["n_votes"] == 6).all()
    # offset-0 items have severity 0: each careful rater says good with its own
    # p_good(0) (formula in annotate/simulate.py), the careless one with 0.5; the observed
    # rate over the 24 items must lie within 4 binomial standard deviations of it
    zero = r[(r["kind"] == "test") & (r["y_offset_m"] == 0)]
    rate = zero.groupby("rater_id")["vote"].agg(["mean", "size"])
    for p in params.itertuples():
        want = 0.5 if p.careless else float(p_good(0.0, theta=p.theta, width=p.width, lapse=p.lapse))
        n = rate.loc[p.rater_id, "size"]
        assert abs(rate.loc[p.rater_id, "mean"] - want) <= 4 * np.sqrt(want * (1 - want) / n) + 1e-9
    assert rate.loc["sim-careless", "mean"] < rate.drop("sim-careless")["mean"].min()


def test_cli_build_add_rater_gvf_and_errors(toy_inputs, tmp_path, capsys):
    scene, pairs = toy_inputs
    st = tmp_path / "st"
    assert main(["build", str(st), "--pairs", str(pairs), "--scene", str(scene), "--tracks", "1",
                 "--frames-per-track", "2", "--size", "48", "--access", "token"]) == 0
    # issue 38, item 15: build names no port (serve's is not known yet) but gives the token
    out = capsys.readouterr().out
    assert "admin token: " in out and "8501" not in out
    assert main(["add-rater", str(st), "ann"]) == 0
    link = capsys.readouterr().out.strip()
    assert link.startswith("http://127.0.0.1:8501/?token=")
    from annotate.study import load_study

    assert load_study(st).store.rater_for_token(link.split("=", 1)[1]) == "ann"
    assert main(["simulate", str(st), "--raters", "2"]) == 0
    assert main(["gvf", str(st), "--out", str(tmp_path / "g.csv")]) == 0
    assert len(pd.read_csv(tmp_path / "g.csv")) == 6  # 1 track x 2 frames x 3 offsets
    assert main(["export", str(tmp_path / "nope"), "--out", str(tmp_path / "r.csv")]) == 2
    assert "expected a study folder" in capsys.readouterr().err
    assert main(["add-rater", str(st), "sim-x"]) == 2


def test_serve_binds_localhost_by_default():
    cmd = serve_command("S")
    assert cmd[cmd.index("--server.address") + 1] == "127.0.0.1"
    assert cmd[cmd.index("--server.headless") + 1] == "true"
    assert cmd[cmd.index("--browser.gatherUsageStats") + 1] == "false"
    assert cmd[cmd.index("--server.fileWatcherType") + 1] == "none"
    assert cmd[cmd.index("--server.enableStaticServing") + 1] == "false"
    from annotate.cli import build_parser

    assert build_parser().parse_args(["serve", "S"]).host == "127.0.0.1"


def test_simulating_again_adds_new_raters_with_votes_or_refuses(make_study, capsys):
    """Issue 29: `annotate simulate --raters 2 --seed 1` on a simulated study used to add raters
    with 0 votes (the ids of the first run, who had voted on everything) and exit 0."""
    s = make_study(tracks=4, frames_per_track=6, votes_per_item=6, n_gold=2)
    first = simulate(s, raters=3, seed=0, progress=False)
    n_tests = len(s.keys("test"))
    assert first["rater_id"].tolist() == ["sim-1", "sim-2", "sim-careless"]
    assert (first["test_votes"] == n_tests).all()  # 3 raters of a 6-vote quota: every test item
    again = simulate(s, raters=2, seed=1, progress=False)
    assert again["rater_id"].tolist() == ["sim-3", "sim-careless-2"]
    votes = ratings_table(s)
    tests = votes[votes["kind"] == "test"]
    assert (again["test_votes"] == n_tests).all()
    assert tests.groupby("rater_id").size().to_dict() == dict.fromkeys(
        ["sim-1", "sim-2", "sim-careless", "sim-3", "sim-careless-2"], n_tests)
    # 5 of 6 votes per item are in: two more raters share the last votes, then no more
    assert main(["simulate", str(s.root), "--raters", "2", "--seed", "2"]) == 0
    out = capsys.readouterr().out
    assert "sim-4" in out and "sim-careless-3" in out and "test_votes" in out
    tests = ratings_table(s).query("kind == 'test'")
    assert (tests.groupby("item_id").size() == 6).all()
    assert tests.groupby("rater_id").size()[["sim-4", "sim-careless-3"]].sum() == n_tests
    before = len(ratings_table(s))
    assert main(["simulate", str(s.root), "--raters", "1", "--seed", "3"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--raters: expected a study whose test items still need votes" in err[0]
    assert len(ratings_table(s)) == before and "sim-5" not in s.store.raters()


def test_simulated_votes_export_in_the_same_order_every_run(make_study):
    # Export orders votes by vote time; simulated votes are stamped by a simulated clock, so two
    # runs with one seed give the same ratings rows in the same order (before, wall-clock
    # milliseconds decided ties, and analyze's logistic fit and bootstrap followed the order).
    runs = []
    for _ in range(2):
        s = make_study(tracks=4, frames_per_track=6, votes_per_item=6, n_gold=2)
        simulate(s, raters=6, seed=4, progress=False)
        r = ratings_table(s)
        assert r["voted_at"].is_monotonic_increasing and r["voted_at"].is_unique
        runs.append(r.drop(columns=["voted_at"]).reset_index(drop=True))
    pd.testing.assert_frame_equal(runs[0], runs[1], check_exact=True)


def test_simulated_votes_are_not_stamped_in_the_future(make_study):
    """The simulated clock advances ~0.9 s per vote; at the end the votes are moved back so
    the last lies at the end of the run (in UTC, like the votes of people), in the same order."""
    from datetime import datetime, timedelta, timezone

    study = make_study()
    start = datetime.now(timezone.utc)
    simulate(study, raters=3, seed=0, progress=False)
    end = datetime.now(timezone.utc)
    v = study.store.votes()
    at = pd.to_datetime(v["voted_at"], utc=True)
    assert len(v) > 20 and at.max() <= end + timedelta(milliseconds=1)
    assert at.max() >= start - timedelta(seconds=1)  # moved back by the lead, not more
    gaps = at.diff().dropna()
    assert (gaps >= pd.Timedelta(0)).all()  # the simulated order is kept
