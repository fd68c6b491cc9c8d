"""Rater-facing defaults (issue 29 item 9): each rater's load printed and capped, training that
starts with clearly different pairs, each key shown once on the buttons, "—" for a missing
value on the admin page.

Expected numbers come from the study's own items.csv (item counts by kind) and the pace
constant of annotate/load.py; the buttons' keys from the Button protos Streamlit sends.
"""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from streamlit.testing.v1 import AppTest

import annotate
from annotate.cli import build_parser, main
from annotate.load import DEFAULT_ITEMS_PER_RATER, SECONDS_PER_VOTE, SESSION_MINUTES
from annotate.study import build_study, load_study

APP = str(Path(annotate.__file__).with_name("app.py"))
_spec = importlib.util.spec_from_file_location("annotate_toy_defaults", Path(__file__).with_name("toy.py"))
toy = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(toy)


def test_default_load_fits_the_session_at_the_stated_pace():
    # 20 minutes at 1.5 s per vote (annotate/load.py gives the pace's sources): 800 items
    assert (SESSION_MINUTES, SECONDS_PER_VOTE) == (20, 1.5)
    assert DEFAULT_ITEMS_PER_RATER == 800 == SESSION_MINUTES * 60 / SECONDS_PER_VOTE
    args = build_parser().parse_args(["build", "st", "--pairs", "p.csv"])
    assert args.items_per_rater == DEFAULT_ITEMS_PER_RATER
    # 'all': no cap (the demo's simulated raters each rate every item, as before the cap)
    assert build_parser().parse_args(["build", "st", "--pairs", "p.csv", "--items-per-rater", "all"]
                                     ).items_per_rater is None
    with pytest.raises(SystemExit):
        build_parser().parse_args(["build", "st", "--pairs", "p.csv", "--items-per-rater", "0"])
    from argparse import Namespace

    from nvrq.commands.demo import demo_steps, method_steps

    for steps, methods in ((demo_steps, None), (method_steps, "a:0.5,b:1.5")):
        opts = Namespace(seed=0, seconds=1.0, size="64x64", offsets="0", methods=methods, raters=2, encoder="e")
        builds = [argv for prog, argv in steps(Path("o"), opts) if argv[0] == "build"]
        assert builds and all(argv[-2:] == ["--items-per-rater", "all"] for argv in builds)


def test_build_prints_the_load_and_a_rater_gets_no_more(toy_inputs, tmp_path, capsys):
    scene, pairs = toy_inputs
    out = tmp_path / "st"
    # 2 tracks x 3 frames x 3 offsets = 18 test items; 2 training, 2 gold, no repeats
    rc = main(["build", str(out), "--pairs", str(pairs), "--scene", str(scene), "--tracks", "2",
               "--frames-per-track", "3", "--training", "2", "--gold", "1", "--repeats", "0",
               "--size", "64x64", "--votes-per-item", "3", "--items-per-rater", "10"])
    assert rc == 0
    items = pd.read_csv(out / "items.csv")
    counts = items["kind"].value_counts()
    # issue 38 item 31: 8 gold cut (GOLD_POOL = 4 x the 2 a rater sees; it was 2), 2 shown to each
    assert (counts["test"], counts["training"], counts["gold"]) == (18, 2, 8)
    # 10 items per rater: 2 training + 2 gold + 6 test; 10 x 1.5 s = 0.25 min -> "about 0 min";
    # 18 test items x 3 votes / 6 per rater = 9 raters
    printed = capsys.readouterr().out.splitlines()
    assert printed[0].endswith("0 repeat items (each rater sees 2 of the 8 gold)")
    line = [x for x in printed if x.startswith("each rater")]
    assert line == ["each rater: up to 10 items (6 of them test items), about 0 min at 1.5 s per "
                    "vote; 9 raters give every test item its 3 votes"]
    study = load_study(out)
    assert study.manifest.items_per_rater == 10 and study.tests_per_rater == 6
    shown = []
    while (key := study.next_item("ann")) is not None:
        shown.append(key)
        assert study.progress("ann")["total"] == 8  # 6 test + 2 gold; training counted apart
        study.store.record_vote("ann", key, 1, response_ms=900)
    kinds = items.set_index("key").loc[shown, "kind"].value_counts().to_dict()
    assert kinds == {"training": 2, "test": 6, "gold": 2}
    # the next rater gets other test items first (balanced by load)
    first_tests = [k for k in shown if items.set_index("key").at[k, "kind"] == "test"]
    bob = study.next_item("bob")
    while items.set_index("key").at[bob, "kind"] == "training":
        study.store.record_vote("bob", bob, 1, response_ms=900)
        bob = study.next_item("bob")
    assert bob not in first_tests


def test_a_cap_below_the_fixed_items_is_refused(toy_inputs, tmp_path, capsys):
    scene, pairs = toy_inputs
    rc = main(["build", str(tmp_path / "st"), "--pairs", str(pairs), "--scene", str(scene),
               "--training", "3", "--gold", "1", "--repeats", "2", "--items-per-rater", "7"])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "--items-per-rater" in err and "7 training" in err
    assert not (tmp_path / "st").exists()


def test_a_study_without_a_cap_gives_every_item(make_study):
    # studies built before the cap (no manifest key) and items_per_rater=None: no cap
    s = make_study(items_per_rater=None)
    assert s.manifest.items_per_rater is None and s.tests_per_rater is None
    assert "max_tests" not in s.new_plan("ann")
    # every test and repeat item, and the rater's share of the gold pool (issue 38 item 31)
    assert s.progress("ann")["total"] == len(s.keys("test")) + s.gold_per_rater + len(s.keys("repeat"))


def test_training_starts_clearly_different():
    from annotate.design import pick_training

    offsets = np.repeat([-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0], 4)
    pairs = pd.DataFrame({"pair_id": [f"p{i}" for i in range(len(offsets))], "y_offset_m": offsets})
    tests = pairs.iloc[::3]
    for n in (1, 3, 5, 10):
        got = pick_training(pairs, tests, n, np.random.default_rng(n))["y_offset_m"].abs().to_numpy()
        assert got[0] >= 2 and got[0] == 3  # the first is the clearest difference there is
        assert np.all(np.diff(got) <= 0)  # then from large to small
        assert not set(tests["pair_id"]) & set(pick_training(pairs, tests, n, np.random.default_rng(0))["pair_id"])
    five = pick_training(pairs, tests, 5, np.random.default_rng(0))["y_offset_m"].abs().tolist()
    assert five[-1] == 0  # the subtle end is covered too


# --- the rater app ---------------------------------------------------------------------------

_KEY_WORDS = {"←": "Left", "→": "Right"}


def _keys_shown(button) -> list[str]:
    """Keys a button shows: its shortcut (Streamlit draws it beside the label) and every key
    its label names, a lone letter or digit (``(G)``) or an arrow."""
    keys = [button.proto.shortcut.upper()] if button.proto.shortcut else []
    keys += [t.upper() for t in re.findall(r"(?<![\w'])[A-Za-z0-9](?![\w'])", button.label)]
    keys += [_KEY_WORDS[c].upper() for c in button.label if c in _KEY_WORDS]
    return keys


def _voting_buttons(study, monkeypatch) -> list:
    monkeypatch.setenv("ANNOTATE_STUDY", str(study.root))
    monkeypatch.setenv("ANNOTATE_MIN_RESPONSE_MS", "0")
    at = AppTest.from_file(APP, default_timeout=30)
    at.query_params["rater"] = "ann"
    at.run()
    at.button(key="start").click().run()
    return [b for b in at.button if b.key]  # every button on screen (the arrow keys: a script)


@pytest.mark.parametrize("design", ["binary", "pairwise"])
def test_buttons_show_each_key_once(design, tmp_path, monkeypatch):
    methods = {"a": 1.0, "b": 1.5} if design == "pairwise" else None
    scene, pairs = toy.make_toy(tmp_path / "in", methods=methods)
    study = load_study(build_study(tmp_path / "st", pairs, scene=str(scene), tracks=1, frames_per_track=1,
                                   n_training=1, n_gold=0, n_repeats=0, size=64, design=design,
                                   progress=False))
    buttons = _voting_buttons(study, monkeypatch)
    keys = [k for b in buttons for k in _keys_shown(b)]
    want = {"binary": ["G", "B", "U"], "pairwise": ["1", "LEFT", "0", "2", "RIGHT", "U"]}[design]
    assert sorted(keys) == sorted(want), [(b.label, b.proto.shortcut) for b in buttons]


def test_admin_page_shows_a_dash_for_missing_values(make_study, monkeypatch):
    from streamlit.dataframe_util import convert_arrow_bytes_to_pandas_df

    from annotate.admin import MISSING

    s = make_study(n_training=1)
    s.store.add_rater("ann", plan=s.new_plan("ann"))
    key = s.next_item("ann")  # a training vote only: no agreement, kappa, ... yet
    s.store.record_vote("ann", key, 1, response_ms=900)
    monkeypatch.setenv("ANNOTATE_STUDY", str(s.root))
    at = AppTest.from_file(APP, default_timeout=30)
    at.query_params["admin"] = s.admin_token()
    at.run()
    assert not at.exception
    table = next(df for df in at.dataframe if "flags" in df.value.columns)
    assert table.value.set_index("rater_id").loc["ann", ["agreement", "kappa"]].isna().all()
    shown = convert_arrow_bytes_to_pandas_df(table.proto.arrow_data.styler.display_values)
    cells = shown.astype(str).to_numpy().ravel().tolist()
    assert MISSING in cells and not {"None", "nan", "NaN", "<NA>"} & set(cells)
