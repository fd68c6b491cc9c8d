"""``nvrq import renders``: a synthetic scene's renders, moved out into a folder in each layout
and imported back, give byte for byte the pairs of the scene with its renders in place."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest

from data_schema.scene import load_scene
from nvrq.cli import main
from nvrq.render_plans import render_plan

CLIP = ["--seed", "1", "--seconds", "1", "--fps", "2", "--size", "320x180", "--offsets=-1,1",
        "--cameras", "pinhole,ftheta", "--quiet"]
PAIRS = ["--min-side", "10", "--quiet"]


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """One synthetic clip, and one rendered by two methods."""
    d = tmp_path_factory.mktemp("renders")
    assert main(["synth", str(d / "one"), *CLIP]) == 0
    assert main(["synth", str(d / "two"), *CLIP, "--methods", "sharp:0.5,blurry:1.5"]) == 0
    return d


def _pairs(scene: Path, out: Path) -> bytes:
    assert main(["pairs", str(scene), "--out", str(out), *PAIRS]) == 0
    return out.read_bytes()


def _move_out(scene: Path, dest: Path, *, layout: str, method: str | None = None) -> list[str]:
    """Move the renders of the scene's plan (of ``method``) into ``dest`` in ``layout``, as a
    renderer would have written them; returns the plan paths in plan order."""
    plan = render_plan(scene, method=method)
    for i, p in enumerate(plan.paths):
        target = dest / p if layout == "plan" else dest / f"{i:05d}.png"
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.move(scene / p, target)
    return plan.paths.tolist()


@pytest.fixture
def one(made, tmp_path):
    """A copy of the one-method clip, its pairs with the renders in place (bytes)."""
    scene = tmp_path / "scene"
    shutil.copytree(made / "one", scene)
    return scene, _pairs(scene, tmp_path / "ref.csv")


@pytest.mark.parametrize("layout", ["plan", "order"])
def test_renders_imported_back_give_the_pairs_of_renders_in_place(one, tmp_path, layout, capsys):
    scene, ref = one
    images = (scene / "images.csv").read_bytes()
    content = {p: (scene / p).read_bytes() for p in render_plan(scene).paths}
    paths = _move_out(scene, tmp_path / "renders", layout=layout)
    assert len(paths) == 2 * 2 * 2 and not any((scene / p).exists() for p in paths)
    capsys.readouterr()
    assert main(["import", "renders", str(scene), str(tmp_path / "renders"), "--layout", layout]) == 0
    out = capsys.readouterr().out
    assert out.count("\n") == 1 and "8 expected, 8 found, 0 missing, 0 unexpected" in out
    assert (scene / "images.csv").read_bytes() == images  # the same rows, the same paths
    assert _pairs(scene, tmp_path / "back.csv") == ref
    assert {p: (scene / p).read_bytes() for p in paths} == content  # each file back at its row
    assert all((tmp_path / "renders" / (p if layout == "plan" else f"{i:05d}.png")).is_file()
               for i, p in enumerate(paths))  # copied, never moved


def test_two_methods_into_a_scene_of_placeholder_rows(made, tmp_path):
    # the two-method clip as an importer leaves it (unnamed render rows, no files), then each
    # method's renders imported, one by order, one by plan: the pairs of the clip as synth wrote it
    scene = tmp_path / "scene"
    shutil.copytree(made / "two", scene)
    ref = _pairs(scene, tmp_path / "ref.csv")
    content = {p: p.read_bytes() for p in scene.rglob("*.png")}
    _move_out(scene, tmp_path / "sharp", layout="order", method="sharp")
    assert main(["render-plan", str(scene), "--method", "blurry", "--out", str(tmp_path / "blurry.csv")]) == 0
    for p in pd.read_csv(tmp_path / "blurry.csv").path:  # the renderer writes where the plan says
        (tmp_path / "blurry" / p).parent.mkdir(parents=True, exist_ok=True)
        shutil.move(scene / p, tmp_path / "blurry" / p)
    images = pd.read_csv(scene / "images.csv", keep_default_na=False)
    gt = images[images.source == "gt"].drop(columns="method")
    placeholders = images[(images.source == "render") & (images.method == "sharp")].drop(columns="method")
    placeholders = placeholders.assign(path=[p.replace("/sharp/", "/") for p in placeholders.path])
    pd.concat([gt, placeholders]).to_csv(scene / "images.csv", index=False)
    assert main(["import", "renders", str(scene), str(tmp_path / "sharp"), "--layout", "order",
                 "--method", "sharp"]) == 0
    assert main(["import", "renders", str(scene), str(tmp_path / "blurry"), "--method", "blurry"]) == 0
    assert _pairs(scene, tmp_path / "back.csv") == ref
    assert set(load_scene(scene).images.method) == {"", "sharp", "blurry"}
    assert {p: p.read_bytes() for p in scene.rglob("*.png")} == content


def test_reimporting_a_method_replaces_its_renders(made, tmp_path):
    scene = tmp_path / "scene"
    shutil.copytree(made / "two", scene)
    ref = _pairs(scene, tmp_path / "ref.csv")
    images = (scene / "images.csv").read_bytes()
    _move_out(scene, tmp_path / "sharp", layout="plan", method="sharp")
    assert main(["import", "renders", str(scene), str(tmp_path / "sharp"), "--method", "sharp"]) == 0
    assert (scene / "images.csv").read_bytes() == images and _pairs(scene, tmp_path / "back.csv") == ref


def test_allow_missing_leaves_the_views_out_of_the_pairs(one, tmp_path, capsys):
    scene, ref = one
    images = (scene / "images.csv").read_bytes()
    paths = _move_out(scene, tmp_path / "renders", layout="order")
    (tmp_path / "renders" / "00003.png").unlink()
    capsys.readouterr()
    argv = ["import", "renders", str(scene), str(tmp_path / "renders"), "--layout", "order"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "8 expected, 7 found, 1 missing, 0 unexpected" in err and paths[3] in err
    assert (scene / "images.csv").read_bytes() == images and not any((scene / p).exists() for p in paths)
    assert main([*argv, "--allow-missing"]) == 0
    assert "1 missing" in capsys.readouterr().out
    back = pd.read_csv(tmp_path / "ref.csv")
    expected = back[back.render_path != paths[3]]
    assert len(expected) < len(back)  # the missing view had pairs
    got = pd.read_csv(pd.io.common.StringIO(_pairs(scene, tmp_path / "back.csv").decode()))
    pd.testing.assert_frame_equal(got, expected.reset_index(drop=True))
    assert paths[3] not in load_scene(scene).images.path.tolist()


def test_refusals_name_whole_files_and_the_option_that_helps(one, tmp_path, capsys):
    scene, _ = one
    paths = _move_out(scene, tmp_path / "renders", layout="plan")
    (tmp_path / "renders" / paths[3]).unlink()
    argv = ["import", "renders", str(scene), str(tmp_path / "renders")]
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"(first missing: {paths[3]})" in err
    assert "(or --allow-missing to leave the views without a render out)" in err, err
    # a long line is shortened between words, never inside a file name
    long = "0_a_file_that_is_no_render_" + "x" * 200 + ".png"
    (tmp_path / "renders" / long).write_bytes(b"")
    assert main(argv) == 2
    err = capsys.readouterr().err.rstrip()
    assert err.endswith(" ...") and "--allow-missing" not in err  # unexpected files: it would not help
    assert err.removesuffix(" ...").endswith("first unexpected"), err  # not a piece of the name
    assert "a_file_that_is_no_render" not in err


def test_link_and_jpeg_files(one, tmp_path):
    scene, ref = one
    paths = _move_out(scene, tmp_path / "renders", layout="order")
    os.replace(tmp_path / "renders" / "00000.png", tmp_path / "renders" / "00000.JPG")  # PNG bytes, any name
    assert main(["import", "renders", str(scene), str(tmp_path / "renders"), "--layout", "order", "--link"]) == 0
    rows = load_scene(scene).images
    first = paths[0].removesuffix(".png") + ".jpg"
    assert first in rows.path.tolist() and paths[0] not in rows.path.tolist()
    assert (scene / first).is_symlink() and (scene / first).resolve() == (tmp_path / "renders" / "00000.JPG")
    assert (scene / paths[1]).is_symlink()
    back = pd.read_csv(pd.io.common.StringIO(_pairs(scene, tmp_path / "back.csv").decode()))
    want = pd.read_csv(tmp_path / "ref.csv").replace({"render_path": {paths[0]: first}})
    pd.testing.assert_frame_equal(back, want)


def test_a_second_method_beside_unnamed_renders_on_disk(one, tmp_path, capsys):
    # a scene whose unnamed renders exist: --method alone is refused; --existing-method names them
    scene, ref = one
    other = tmp_path / "other"
    other.mkdir()
    for i, p in enumerate(render_plan(scene).paths):  # the second method's renders: copies, by order
        shutil.copy(scene / p, other / f"{i:05d}.png")
    before = (scene / "images.csv").read_bytes()
    argv = ["import", "renders", str(scene), str(other), "--layout", "order", "--method", "b"]
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "8 unnamed renders on disk" in err
    assert (scene / "images.csv").read_bytes() == before
    assert main(["import", "renders", str(scene), str(other), "--layout", "order"]) == 0  # no method: fine
    assert main([*argv, "--existing-method", "a"]) == 0
    images = load_scene(scene).images
    renders = images[images.source == "render"]
    assert sorted(renders.method.value_counts().items()) == [("a", 8), ("b", 8)]
    assert all("/b/" in p for p in renders.path[renders.method == "b"])
    assert all("/a/" not in p for p in renders.path[renders.method == "a"])  # a's paths stay
    pairs = pd.read_csv(pd.io.common.StringIO(_pairs(scene, tmp_path / "p.csv").decode()))
    n = len(pd.read_csv(pd.io.common.StringIO(ref.decode())))
    assert pairs.groupby("method").size().to_dict() == {"a": n, "b": n}
    # now every import names a method
    capsys.readouterr()
    assert main(["import", "renders", str(scene), str(other), "--layout", "order"]) == 2
    assert "--method: expected a method name: the scene's renders name methods (a, b)" in capsys.readouterr().err


def _write(path: Path, image: np.ndarray | bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(image, bytes):
        path.write_bytes(image)
    else:
        assert cv2.imwrite(str(path), image)


@pytest.mark.parametrize("case, expected", [
    ("unexpected", "8 expected, 8 found, 0 missing, 1 unexpected (first unexpected: notes/stray.png)"),
    ("size", "an image of camera front's size 320x180, got 100x50): expected readable images"),
    ("unreadable", "an undecodable file): expected readable images of their camera's size, got 1 bad render"),
    ("method", "--method: expected a method name"),
    ("no_renders", "images.csv: column source: expected render rows"),
    ("same_folder", "DIR: expected a folder of renders other than the scene folder"),
    ("layout", "--layout: invalid choice"),
])
def test_bad_input_is_one_line_and_changes_nothing(one, tmp_path, capsys, case, expected):
    scene, _ = one
    renders = tmp_path / "renders"
    paths = _move_out(scene, renders, layout="plan")
    argv = ["import", "renders", str(scene), str(renders)]
    if case == "unexpected":
        _write(renders / "notes" / "stray.png", np.zeros((4, 4, 3), np.uint8))
    elif case == "size":
        _write(renders / paths[2], np.zeros((50, 100, 3), np.uint8))
    elif case == "unreadable":
        _write(renders / paths[5], b"not a png")
    elif case == "method":
        argv += ["--method", "a:b"]
    elif case == "no_renders":
        images = pd.read_csv(scene / "images.csv")
        images[images.source == "gt"].to_csv(scene / "images.csv", index=False)
    elif case == "same_folder":
        argv[3] = str(scene)
    else:
        argv += ["--layout", "sideways"]
    before = {p: p.read_bytes() for p in scene.rglob("*") if p.is_file()}
    capsys.readouterr()
    rc = main(argv)
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and expected in err, err
    assert {p: p.read_bytes() for p in scene.rglob("*") if p.is_file()} == before


def test_order_layout_names(one, tmp_path, capsys):
    # exactly {i:05d} + .png/.jpg/.jpeg: 0001.png, 000001.png and a ninth row are not renders of the plan
    scene, _ = one
    renders = tmp_path / "renders"
    _move_out(scene, renders, layout="order")
    for name in ("0001.png", "000001.png", "00008.png", "00002.tif", ".hidden.png"):
        shutil.copy(renders / "00000.png", renders / name)
    capsys.readouterr()
    assert main(["import", "renders", str(scene), str(renders), "--layout", "order"]) == 2
    assert "8 found, 0 missing, 4 unexpected (first unexpected: 000001.png)" in capsys.readouterr().err
    for name in ("0001.png", "000001.png", "00008.png", "00002.tif"):
        (renders / name).unlink()
    shutil.copy(renders / "00000.png", renders / "00000.jpeg")
    assert main(["import", "renders", str(scene), str(renders), "--layout", "order"]) == 2
    assert "one file per plan row, got 00000.jpeg and 00000.png" in capsys.readouterr().err


def test_reimporting_other_files_needs_replace_and_says_how_many_changed(one, tmp_path, capsys):
    # issue 38 item 3: the scene's renders are on disk; a second import of other files would make
    # the pairs and metrics made from them stale: refused without --replace, counted with it
    scene, ref = one
    images = (scene / "images.csv").read_bytes()
    plan = render_plan(scene)
    before = {p: (scene / p).read_bytes() for p in plan.paths}
    new = tmp_path / "new"
    for i, p in enumerate(plan.paths):
        (new / p).parent.mkdir(parents=True, exist_ok=True)
        img = cv2.imread(str(scene / p))
        if i in (2, 5):  # two renders change, the other six are the same bytes
            img = 255 - img
        cv2.imwrite(str(new / p), img) if i in (2, 5) else shutil.copyfile(scene / p, new / p)
    capsys.readouterr()
    argv = ["import", "renders", str(scene), str(new)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--replace" in err and "2 render files that would change" in err
    assert {p: (scene / p).read_bytes() for p in plan.paths} == before  # nothing changed
    assert (scene / "images.csv").read_bytes() == images
    assert main([*argv, "--replace"]) == 0
    assert "replaced: 2 render files changed" in capsys.readouterr().out
    assert (scene / plan.paths[2]).read_bytes() == (new / plan.paths[2]).read_bytes()
    # the same files again change nothing: no --replace needed, nothing counted
    assert main(argv) == 0
    assert "replaced" not in capsys.readouterr().out


def test_order_layout_names_the_missing_file_to_supply(one, tmp_path, capsys):
    # issue 38 item 12: the user supplies 00003.png; the message names it (and the plan path)
    scene, _ = one
    paths = _move_out(scene, tmp_path / "renders", layout="order")
    (tmp_path / "renders" / "00003.png").unlink()
    capsys.readouterr()
    assert main(["import", "renders", str(scene), str(tmp_path / "renders"), "--layout", "order"]) == 2
    err = capsys.readouterr().err
    assert f"first missing: 00003.png (for {paths[3]})" in err


def test_a_link_loop_in_the_renders_is_walked_once_and_said(one, tmp_path, capsys):
    """Links back to a folder above are not followed (os.walk(followlinks=True) took exponential
    time on them); the import succeeds, says how many folders it did not walk, in well under 5 s."""
    import time

    scene, _ = one
    renders = tmp_path / "renders"
    _move_out(scene, renders, layout="plan")
    for i in range(8):
        (renders / "images" / f"up{i}").symlink_to("..")
    t0 = time.perf_counter()
    assert main(["import", "renders", str(scene), str(renders), "--replace"]) == 0
    assert time.perf_counter() - t0 < 5
    out = capsys.readouterr().out
    assert "8 linked folders not walked (a link loop or too deep)" in out and "first not walked: images/up0" in out
