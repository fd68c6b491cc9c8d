"""The benchmark scripts run (tiny sizes) and print numbers that agree with each other.

Speeds are not asserted here (the machine is shared and noisy); the scripts measure and
print them side by side. What is asserted: every script exits 0, prints its ratio lines
with finite positive numbers, and each printed ratio is the quotient of the printed
quantities it is defined from (so a ratio line cannot silently print something else).
"""

from __future__ import annotations

import math
import re
import subprocess
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
NUM = r"([0-9][0-9,]*\.?[0-9]*)"


def _run(script: str, *argv: str) -> str:
    proc = subprocess.run([sys.executable, str(BENCH / script), *argv], capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc.stdout


def _number(text: str, pattern: str) -> float:
    """The first number captured by ``pattern`` (``NUM`` marks it) in ``text``."""
    m = re.search(pattern.replace("NUM", NUM), text)
    assert m, f"no line matching {pattern!r} in:\n{text[-2000:]}"
    value = float(m.group(1).replace(",", ""))
    assert math.isfinite(value)
    return value


def _close(ratio: float, num: float, den: float, *, printed_digits: int) -> bool:
    """``ratio == num / den`` to the rounding of the printed numbers."""
    return ratio == pytest.approx(num / den, rel=0.05, abs=10.0**-printed_digits)


@pytest.mark.slow
def test_bench_pairs_prints_the_vectorised_over_loop_speedup():
    out = _run("bench_pairs.py", "--tracks", "6", "--frames", "12", "--loop-sample", "50")
    rate_vec = _number(out, r"vectorised make_pairs: [0-9.]+ s, NUM box-pairs/s")
    rate_loop = _number(out, r"per-box cv2.projectPoints loop: \d+ boxes in [0-9.]+ s, NUM box-pairs/s")
    speedup = _number(out, r"speed-up \(vectorised / loop\): NUMx")
    assert rate_vec > 0 and rate_loop > 0
    assert _close(speedup, rate_vec, rate_loop, printed_digits=1)


@pytest.mark.slow
def test_bench_synth_prints_images_per_second_per_camera():
    out = _run("bench_synth.py", "--seconds", "0.2", "--size", "160x96")
    n_images = _number(out, r": NUM images in [0-9.]+ s")
    wall = _number(out, r"images in NUM s")
    per_cam = _number(out, r"images per second per camera: NUM")
    n_cams = len(re.search(r"cameras (\S+?):", out).group(1).split(","))
    assert n_images > 0
    assert _close(per_cam, n_images / n_cams, wall, printed_digits=2)


@pytest.mark.slow
def test_bench_score_ratios_are_quotients_of_the_printed_rates():
    out = _run("bench_score.py", "--pairs", "14", "--naive-pairs", "4", "--batch-size", "8",
               "--random-scene")
    per_pair = _number(out, r"encoder_images_per_pair\s+NUM")
    a = _number(out, r"a_encoder_images_per_s\s+NUM")
    b = _number(out, r"b_pipeline_pairs_per_s\s+NUM")
    naive = _number(out, r"naive_pairs_per_s\s+NUM")
    # definitions in bench_score.py's docstring: c = images per pair / 2 (naive embeds both
    # crops), d = b / (a / images per pair), e = b / naive
    assert _close(_number(out, r"c_encoder_images_vs_naive\s+NUM"), per_pair, 2.0, printed_digits=3)
    assert _close(_number(out, r"d_fraction_of_encoder_bound\s+NUM"), b * per_pair, a,
                  printed_digits=3)
    assert _close(_number(out, r"e_speedup_over_naive\s+NUM"), b, naive, printed_digits=3)
    # GT reuse: 14 pairs share GT crops across offsets, so fewer than 2 images per pair
    assert per_pair < 2.0
    assert re.search(r"^targets: .*c <= 0\.6: (met|MISSED)", out, re.M)


@pytest.mark.slow
def test_bench_analyze_prints_stage_times_and_a_sensible_summary():
    out = _run("bench_analyze.py", "--rows", "20000")
    for stage in (r"summary table \(plcc, srcc, krcc, roc_auc, logistic plcc\): NUM s",
                  r"per-offset table: NUM s", r"analysis total NUM s"):
        assert _number(out, stage) >= 0
    rows = {m.group(1): m.group(2).split()
            for m in re.finditer(r"^\s*(m\d)\s+(.*)$", out, re.M)}
    assert sorted(rows) == ["m0", "m1", "m2"]
    n = {k: int(v[0]) for k, v in rows.items()}
    srcc = {k: float(v[2]) for k, v in rows.items()}
    assert set(n.values()) == {20000}
    # make_items adds noise of sd 0.1, 0.2, 0.3 to the same quality: SRCC must fall with k
    assert 1 > srcc["m0"] > srcc["m1"] > srcc["m2"] > 0


@pytest.mark.slow
def test_bench_raters_loses_no_vote():
    out = _run("bench_raters.py", "--raters", "2", "--seconds", "4", "--think", "0.4", "0.6",
               "--frames", "2")
    assert "0 votes lost" in out, out[-2000:]
