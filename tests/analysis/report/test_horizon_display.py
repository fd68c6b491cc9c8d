"""How the report shows the trust horizon: a bracket stands beside the number it is the
interval of (the crossing, not the grid offset below it), an interval that misses its
estimate is left out with the reason, and the heat strip tells "no objects in this window"
from "not good even at the recorded view", each with its own colour and legend entry."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from matplotlib.colors import to_rgba

import nvrq.horizon as hz
from analysis.report.horizon_report import (
    FAILS_COLOUR,
    NO_DATA_COLOUR,
    _table_display,
    method_sentence,
    timeline_figure,
)


def _random_scores(seed: int) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    rows = []
    for t in range(12):  # 6 tracks per class: enough for an interval
        p = rng.uniform(0.7, 1.0)
        for y in (-2.0, -1.0, 0.0, 1.0, 2.0):
            for _ in range(int(rng.integers(1, 4))):
                rows.append({"track_id": f"t{t}", "label_class": ["car", "bus"][t % 2], "y_offset_m": y,
                             "m": float(rng.random() < p * (1 - 0.15 * abs(y)))})
    return pd.DataFrame(rows)


def _brackets(text: str) -> list[tuple[float, float, float]]:
    """(number before the bracket, lo, hi) of every ``X [lo, hi]`` in ``text``."""
    import re

    return [(float(a), float(b), float(c)) for a, b, c in
            re.findall(r"(-?[\d.]+)(?:\)| [a-z]+)?\s*\[(-?[\d.]+), (-?[\d.]+)\]", text)]


def test_every_bracket_contains_the_number_it_follows():
    shown = 0
    for seed in range(20):
        table = hz.trust_horizon(_random_scores(seed), threshold=0.5, metric="m", share=0.8, n_boot=200, seed=0)
        finite = table[np.isfinite(table["ci_lo"])]
        # the crossing; nothing fails: the largest offset (the horizon); the first fails: 0
        est = finite["crossing"].fillna(finite["horizon"]).fillna(0.0)
        assert ((finite["ci_lo"] - 1e-9 <= est) & (est <= finite["ci_hi"] + 1e-9)).all(), seed
        sentence = method_sentence("all", table)
        for value, lo, hi in _brackets(sentence):  # rounded to 2 decimals in the sentence
            assert lo - 0.006 <= value <= hi + 0.006, (seed, sentence)
        for cell in _table_display(table)["crossing [95% interval]"]:
            for value, lo, hi in _brackets(cell):
                assert lo <= value <= hi, (seed, cell)
                shown += 1
    assert shown > 20  # the check above saw intervals

def test_the_sentence_puts_the_bracket_after_the_crossing():
    # horizon 0 m with a crossing at 0.3 m: "0 m left [0.16, 0.83]" read as an estimate outside its bracket
    row = {"method": "m", "label_class": "car", "axis": "y", "direction": "left", "horizon": 0.0,
           "crossing": 0.3, "ci_lo": 0.16, "ci_hi": 0.83, "reason": ""}
    assert method_sentence("m", pd.DataFrame([row])) == "m: car stays good to 0 m left (crossing 0.3 [0.16, 0.83])."


def test_an_interval_that_misses_its_estimate_is_left_out(monkeypatch):
    scores = _random_scores(3)
    plain = hz.trust_horizon(scores, threshold=0.5, metric="m", share=0.8, n_boot=200, seed=0)
    crossings = hz._crossings

    def shifted(share, grid, s):  # every bootstrap replicate 10 m further out than the data
        return crossings(share, grid, s) + (10.0 if share.shape[0] > 1 else 0.0)

    monkeypatch.setattr(hz, "_crossings", shifted)
    moved = hz.trust_horizon(scores, threshold=0.5, metric="m", share=0.8, n_boot=200, seed=0)
    had = np.isfinite(plain["ci_lo"])
    assert had.any()
    assert moved.loc[had, "ci_lo"].isna().all() and moved.loc[had, "ci_hi"].isna().all()
    assert moved.loc[had, "reason"].str.contains("the estimate lies outside its bootstrap interval").all()
    assert moved["crossing"].equals(plain["crossing"]) and moved["horizon"].equals(plain["horizon"])


def test_the_heat_strip_tells_missing_windows_from_failing_ones():
    base = {"clip_id": "c", "camera": "front", "axis": "y", "method": "m", "ci_lo": math.nan, "ci_hi": math.nan,
            "n_objects": 4}
    rows = [
        {**base, "t0_us": 0, "t1_us": 2_000_000, "direction": "left", "class": "car", "horizon": 1.0},
        {**base, "t0_us": 2_000_000, "t1_us": 4_000_000, "direction": "left", "class": "car", "horizon": math.nan},
        {**base, "t0_us": 0, "t1_us": 2_000_000, "direction": "right", "class": "car", "horizon": 2.0},
    ]  # car right has no objects in the second window; car left fails there at the recorded view
    fig = timeline_figure(pd.DataFrame(rows))
    (legend,) = fig.legends
    assert [t.get_text() for t in legend.get_texts()] == ["not good even at the recorded view",
                                                          "no objects in this window"]
    overlay = fig.axes[0].images[1].get_array()
    labels = [t.get_text() for t in fig.axes[0].get_yticklabels()]
    left, right = labels.index("m · car · front · y left"), labels.index("m · car · front · y right")
    assert tuple(overlay[left, 1]) == to_rgba(FAILS_COLOUR) and tuple(overlay[right, 1]) == to_rgba(NO_DATA_COLOUR)
    assert overlay[left, 0][3] == 0 and overlay[right, 0][3] == 0  # a horizon: its viridis colour shows
