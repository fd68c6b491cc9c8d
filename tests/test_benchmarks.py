"""The benchmark scripts run (tiny sizes) and print their ratios, so they cannot rot.

Speeds are not asserted here (the machine is shared and noisy); the scripts themselves
measure and print them side by side. Only that they run and print the ratio lines.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"

CASES = {
    "bench_pairs.py": (["--tracks", "6", "--frames", "12", "--loop-sample", "50"], "speed-up (vectorised / loop)"),
    "bench_visibility.py": (["--seconds", "0.4", "--size", "320x180", "--tracks", "6", "--frames", "10",
                             "--rounds", "1"], "visibility per 100k object views"),
    "bench_synth.py": (["--seconds", "0.2", "--size", "160x96"], "images per second per camera"),
    "bench_score.py": (["--pairs", "14", "--pipeline-seconds", "0.5", "--rounds", "1", "--naive-pairs", "4", "--batch-sizes", "8",
                        "--random-scene", "--seconds", "0.2", "--encoders", "efficientnet-lite0", "--int8", "",
                        "--methods", "2", "--methods-seconds", "0.2"],
                       "methods_speedup_shared"),
    "bench_metrics.py": (["--seconds", "0.2", "--size", "320x180", "--max-pairs", "30", "--rounds", "1"],
                         "no-reference metrics at >= 50 crops/s"),
    "bench_proxy.py": (["--crops", "8", "--batch-size", "4", "--rounds", "1"], "ratio vs torch"),
    "bench_analyze.py": (["--items", "300", "--raters", "4", "--pairs", "20000", "--clips", "12"],
                         "ratings rows/s over pairs rows/s"),
    "bench_analyze_pairs.py": (["--rows", "20000", "--clips", "12"], "peak RSS"),
    "bench_api.py": (["--seconds", "0.4", "--size", "320x180", "--rounds", "1", "--runtime", "torch",
                      "--calls", "3"], "function / Evaluator"),
    "bench_raters.py": (["--raters", "2", "--seconds", "4", "--think", "0.4", "0.6", "--frames", "2"],
                        "0 votes lost"),
    "bench_import.py": (["--frames", "6", "--size", "160x96", "--rounds", "1"], "import/copy"),
    "bench_nta.py": (["--images", "2000", "--loop-images", "50"], "speed-up (vectorised / loop)"),
    "bench_sets.py": (["--seconds", "0.2", "--size", "160x96", "--offsets", "0,2", "--kid-n", "30",
                       "--kid-sets", "1"], "speed-up (before / after)"),
    "bench_cli_help.py": (["--rounds", "1", "--programs", "annotate,analyze"], "target (every --help"),
    "bench_sampling.py": (["--seeds", "1", "--pair-items", "6", "--reps", "1", "--items", "40",
                           "--max-votes-per-item", "7"], "target: active reaches uniform's final RMSE"),
}


@pytest.mark.slow
@pytest.mark.parametrize("script", list(CASES))
def test_benchmark_runs_and_prints_its_numbers(script):
    argv, expected = CASES[script]
    proc = subprocess.run([sys.executable, str(BENCH / script), *argv], capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert expected in proc.stdout, proc.stdout[-2000:]
