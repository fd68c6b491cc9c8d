"""Symbolically linked image data (issue 23 item 1, docs/FORMATS.md §7): an image folder linked
from other storage is followed by default; ``..`` and absolute paths are still refused on the
text; ``--no-follow-links`` / ``NVRQ_NO_FOLLOW_LINKS=1`` refuse a link that leaves the scene."""

from __future__ import annotations

import shutil

import pandas as pd
import pytest

from annotate.cli import main as annotate_main
from data_schema.errors import InputError
from data_schema.scene import load_scene
from data_schema.tables import NO_FOLLOW_LINKS_ENV, no_follow_links
from nvrq.cli import main as nvrq_main


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    """The same synthetic scene twice: ``plain`` with its images inside, and ``linked`` whose
    ``images`` folder is a symlink to a copy on "another disk" (a folder outside the scene)."""
    root = tmp_path_factory.mktemp("links")
    assert nvrq_main(["synth", str(root / "plain"), "--seconds", "1", "--size", "320x180",
                      "--offsets", "0,1", "--quiet"]) == 0
    linked = root / "linked"
    linked.mkdir()
    for name in ("scene.json", "images.csv"):
        shutil.copy(root / "plain" / name, linked / name)
    shutil.copytree(root / "plain" / "images", root / "storage" / "renders")
    (linked / "images").symlink_to(root / "storage" / "renders", target_is_directory=True)
    return root


def _one_line_error(capsys, *fragments):
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: ") and "Traceback" not in err, err
    for f in fragments:
        assert f in err, (f, err)


def test_a_linked_image_folder_is_followed_by_pairs_and_score(scenes, capsys):
    root = scenes
    for name in ("plain", "linked"):
        assert nvrq_main(["pairs", str(root / name), "--out", str(root / f"{name}-pairs.csv"), "--quiet"]) == 0
        assert nvrq_main(["score", str(root / f"{name}-pairs.csv"), "--out", str(root / f"{name}-m.csv"),
                          "--metrics", "psnr,ssim", "--quiet"]) == 0
    plain, linked = (pd.read_csv(root / f"{n}-pairs.csv") for n in ("plain", "linked"))
    assert len(linked) > 0
    pd.testing.assert_frame_equal(linked.drop(columns="scene_root"), plain.drop(columns="scene_root"))
    # the linked images are the same bytes: the same scores, pair for pair
    pd.testing.assert_frame_equal(pd.read_csv(root / "linked-m.csv"), pd.read_csv(root / "plain-m.csv"))
    assert len(load_scene(root / "linked").images) == len(load_scene(root / "plain").images)


def test_strict_mode_refuses_the_link_that_leaves_the_scene(scenes, tmp_path, capsys, monkeypatch):
    root = scenes
    with pytest.raises(InputError, match="symlink leaves it"):
        load_scene(root / "linked", follow_links=False)
    with no_follow_links(), pytest.raises(InputError, match="symlink leaves it"):
        load_scene(root / "linked")
    assert len(load_scene(root / "linked").images) > 0  # the variable was restored
    assert nvrq_main(["pairs", str(root / "linked"), "--out", str(tmp_path / "p.csv"), "--no-follow-links"]) == 2
    _one_line_error(capsys, "images.csv", "column path", "symlink leaves it", "--no-follow-links")
    pairs = root / "linked-pairs.csv"
    if not pairs.exists():
        assert nvrq_main(["pairs", str(root / "linked"), "--out", str(pairs), "--quiet"]) == 0
        capsys.readouterr()
    assert nvrq_main(["score", str(pairs), "--out", str(tmp_path / "m.csv"), "--metrics", "psnr",
                      "--no-follow-links"]) == 2
    _one_line_error(capsys, "gt_path", "symlink leaves it")
    assert annotate_main(["build", str(tmp_path / "st"), "--pairs", str(pairs), "--tracks", "1",
                          "--frames-per-track", "1", "--no-follow-links"]) == 2
    _one_line_error(capsys, "symlink leaves it")
    monkeypatch.setenv(NO_FOLLOW_LINKS_ENV, "1")  # the documented variable, without the option
    assert nvrq_main(["score", str(pairs), "--out", str(tmp_path / "m.csv"), "--metrics", "psnr"]) == 2
    _one_line_error(capsys, "gt_path", "symlink leaves it")
    assert not any(tmp_path.iterdir())  # nothing written by the refused runs


@pytest.mark.parametrize("strict", [False, True])
@pytest.mark.parametrize("bad", ["../plain/images/front/gt/0.png", "/etc/passwd"])
def test_dotdot_and_absolute_paths_are_refused_in_both_modes(scenes, tmp_path, capsys, strict, bad):
    root = scenes
    pairs = root / "plain-pairs.csv"
    if not pairs.exists():
        assert nvrq_main(["pairs", str(root / "plain"), "--out", str(pairs), "--quiet"]) == 0
        capsys.readouterr()
    df = pd.read_csv(pairs)
    df.loc[0, "gt_path"] = bad
    df.to_csv(tmp_path / "bad.csv", index=False)
    flag = ["--no-follow-links"] if strict else []
    assert nvrq_main(["score", str(tmp_path / "bad.csv"), "--out", str(tmp_path / "m.csv"), "--metrics", "psnr",
                      *flag]) == 2
    _one_line_error(capsys, "gt_path", "a path inside the scene folder (relative, no '..')", bad)
    assert not (tmp_path / "m.csv").exists()


def test_ray_decode_task_applies_the_drivers_link_rule(scenes):
    """The Ray engine's CPU task gets the driver's rule (a worker's environment may differ)."""
    from nvrq.engines.ray_engine import _decode_shard
    from nvrq.engines.scorers import MetricScorer
    from nvrq.engines.shards import Shard

    root = scenes
    pairs = root / "linked-pairs.csv"
    if not pairs.exists():
        assert nvrq_main(["pairs", str(root / "linked"), "--out", str(pairs), "--quiet"]) == 0
    shard = Shard(0, "c", str(pairs), (0, 1, 2), str(root))
    scorer = MetricScorer(("psnr",))
    assert "payload" in _decode_shard({"shard": shard}, scorer=scorer, follow=True)
    with pytest.raises(InputError, match="symlink leaves it"):
        _decode_shard({"shard": shard}, scorer=scorer, follow=False)
