"""Issue 34 item 6: the analyses, the method comparison and study building take frozen options,
made once from the CLI (``options_from_args``) or by an API caller; the former keyword spelling
gives the same options."""

from __future__ import annotations

import dataclasses

import pytest

from analysis.cli import build_parser, options_from_args
from analysis.options import AnalysisOptions, MethodOptions, SummaryOptions, analysis_options
from annotate.commands.build import options_from_args as study_options_from_args
from annotate.design import StudyOptions
from annotate.study import build_study
from data_schema.options import options_or_keywords


def test_the_cli_builds_the_options_once_from_its_arguments():
    args = build_parser().parse_args(["r.csv", "--out", "rep", "--metrics-table", "m.csv", "--bootstrap", "7",
                                      "--seed", "3", "--compare-methods", "--methods", "a,b",
                                      "--leaderboard-metric", "psnr", "--by", "class", "--quiet"])
    o = options_from_args(args)
    # each value as given on the command line above
    assert (o.metrics_paths, o.n_boot, o.seed, o.progress) == (["m.csv"], 7, 3, False)
    assert o.compare == MethodOptions(methods=["a", "b"], rank_metric="psnr", by=["class"])
    assert options_from_args(build_parser().parse_args(["r.csv", "--out", "rep"])).compare is None
    with pytest.raises(dataclasses.FrozenInstanceError):
        o.seed = 1


def test_the_former_keywords_give_the_same_options():
    legacy = analysis_options({"n_boot": 5, "compare_methods": True, "rank_metric": "psnr", "min_clusters": 3})
    assert legacy == AnalysisOptions(n_boot=5, compare=MethodOptions(rank_metric="psnr", min_clusters=3))
    # method keywords without compare_methods were ignored before, and still are
    assert analysis_options({"methods": ["a"]}) == AnalysisOptions()
    assert options_or_keywords(SummaryOptions, None, {"rank_by": "plcc"}, who="f") == SummaryOptions(rank_by="plcc")
    with pytest.raises(TypeError, match="not both"):
        analysis_options({"n_boot": 5}, options=AnalysisOptions())
    with pytest.raises(TypeError, match="unexpected keyword argument 'bootstrap'"):
        analysis_options({"bootstrap": 5})


def test_study_options_from_the_cli_and_from_keywords(tmp_path):
    from annotate.cli import build_parser as annotate_parser

    args = annotate_parser().parse_args(["build", str(tmp_path / "st"), "--pairs", "p.csv", "--tracks", "4",
                                         "--size", "64x64", "--metrics-table", "m.csv", "--gold", "2"])
    o = study_options_from_args(args)
    assert o == StudyOptions(tracks=4, size=64, metrics_paths=("m.csv",), n_gold=2)
    with pytest.raises(TypeError, match="not both"):
        build_study(tmp_path / "st", "p.csv", o, tracks=3)
    with pytest.raises(TypeError, match="unexpected keyword argument 'n_tracks'"):
        build_study(tmp_path / "st", "p.csv", n_tracks=3)
