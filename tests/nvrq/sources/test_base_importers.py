"""Importers share one shape (issue 34 item 5) and scene outputs are written whole (issue 38 item 4).

A toy importer, one module (this file) and one :class:`ImporterCommand`, goes through the
:class:`nvrq.sources.base.Importer` protocol into the one writer and comes back as a valid scene;
a bad scene from it is refused by the writer with one line, nothing written; ``nvrq`` learns its
input argument from the registration.
"""

from __future__ import annotations

import json
import os
import shutil
import stat
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest

from data_schema.errors import InputError
from data_schema.scene import CameraCalib, Track, load_scene
from data_schema.scene_writer import NewScene, SceneFrame, scene_images, write_scene
from nvrq.cli import INPUT_ARGS, main
from nvrq.commands import imports
from nvrq.sources.base import ImportedScene, Importer, describe, plan_render_path

CLIP = ["--seed", "1", "--seconds", "1", "--fps", "2", "--size", "160x90", "--offsets=-1,1", "--quiet"]


class ToyImporter:
    """Reads ``SRC/toy.json`` (``dims``: the one box's [l, w, h]) and ``SRC/frame.png``."""

    def read(self, path) -> ImportedScene:
        src = Path(path)
        dims = json.loads((src / "toy.json").read_text())["dims"]
        model = {"type": "pinhole", "resolution": [64, 48], "focal_length": [40.0, 40.0],
                 "principal_point": [32.0, 24.0]}
        T_sr = np.array([[0, 0, 1, 0], [-1, 0, 0, 0], [0, -1, 0, 0], [0, 0, 0, 1]], float).T  # camera -> rig
        track = Track("car-1", "automobile", np.asarray(dims, float), np.array([0]),
                      np.array([[8.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]]))
        scene = NewScene("toy-clip", {"front": CameraCalib("front", T_sr, model)}, np.array([0]),
                         np.eye(4)[None], [track], [SceneFrame("front", 0, "images/front/gt/0.png", src / "frame.png")])
        return ImportedScene(scene, np.array([[0, 1.0, 0, 0, 0, 0]]), detail="toy")


IMPORTER = ToyImporter()


def _toy_inputs(p) -> None:
    p.add_argument("src", help="toy source folder")


@pytest.fixture
def toy(monkeypatch, tmp_path):
    """The toy importer registered as ``nvrq import toy SRC OUT``, and a source folder."""
    monkeypatch.setattr(imports, "IMPORTERS", [*imports.IMPORTERS, imports.ImporterCommand(
        "toy", __name__, ("src",), _toy_inputs, "a toy source", "A toy source for the tests.")])
    src = tmp_path / "src"
    src.mkdir()
    cv2.imwrite(str(src / "frame.png"), np.full((48, 64, 3), 90, np.uint8))
    (src / "toy.json").write_text(json.dumps({"dims": [4.0, 2.0, 1.5]}))
    return src


def test_toy_importer_gives_a_valid_scene_through_the_one_writer(toy, tmp_path, capsys):
    assert isinstance(IMPORTER, Importer)
    assert main(["import", "toy", str(toy), str(tmp_path / "out")]) == 0
    # one frame, one camera, one track: singular nouns (issue 38 item 17)
    assert capsys.readouterr().out == f"wrote {tmp_path / 'out'} (toy: 1 frame x 1 camera, 1 track)\n"
    scene = load_scene(tmp_path / "out", check_images=False)
    assert scene.clip_id == "toy-clip" and [t.track_id for t in scene.tracks] == ["car-1"]
    assert scene.images.path.tolist() == ["images/front/gt/0.png", "images/front/render_+1.00/0.png"]
    assert (tmp_path / "out" / "images/front/gt/0.png").read_bytes() == (toy / "frame.png").read_bytes()


def test_a_bad_scene_from_an_importer_is_refused_with_one_line_and_nothing_written(toy, tmp_path, capsys):
    (toy / "toy.json").write_text(json.dumps({"dims": [4.0, -2.0, 1.5]}))
    assert main(["import", "toy", str(toy), str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.startswith(f"error: {tmp_path / 'out' / 'scene.json'}: tracks[0].dims_lwh: expected positive")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["src"]  # no folder, no temporary folder


def test_the_cli_learns_the_importers_inputs_from_its_registration(toy, tmp_path, capsys):
    before = sorted(p.name for p in toy.iterdir())
    assert main(["import", "toy", str(toy), str(toy)]) == 2
    assert "OUT: expected an output path that is not an input" in capsys.readouterr().err
    assert sorted(p.name for p in toy.iterdir()) == before
    assert "src" not in INPUT_ARGS  # not in the list of cli.py: from the registration


def test_writer_refuses_a_frame_without_its_row(tmp_path):
    T_sr = np.eye(4)
    model = {"type": "pinhole", "resolution": [8, 8], "focal_length": [4.0, 4.0], "principal_point": [4.0, 4.0]}
    scene = NewScene("c", {"front": CameraCalib("front", T_sr, model)}, np.array([0]), np.eye(4)[None], [],
                     [SceneFrame("front", 0, "images/front/gt/0.png")])
    images = scene_images(scene, np.zeros((1, 6)), plan_render_path)
    with pytest.raises(InputError, match=r"images.csv: column path: expected a row for the GT image x.png"):
        write_scene(NewScene(**{**scene.__dict__, "frames": [*scene.frames, SceneFrame("front", 0, "x.png")]}),
                    tmp_path / "o", images=images)
    assert not (tmp_path / "o").exists()
    assert describe(ImportedScene(scene, np.zeros((1, 6)))) == "1 frame x 1 camera, 0 tracks"


def test_import_over_an_existing_scene_leaves_none_of_its_files(toy, tmp_path):
    # issue 38 item 4: synth then import into the same folder: the stale degradation.csv and the
    # synth renders are gone, the folder holds the imported scene only
    out = tmp_path / "scene"
    assert main(["synth", str(out), *CLIP]) == 0
    assert (out / "degradation.csv").is_file()
    assert main(["import", "toy", str(toy), str(out)]) == 0
    files = sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file())
    assert files == ["images.csv", "images/front/gt/0.png", "scene.json"]


def test_synth_over_an_existing_scene_is_written_whole(tmp_path):
    out = tmp_path / "scene"
    assert main(["synth", str(out), *CLIP[:-2], "--offsets=-2,2", "--quiet"]) == 0
    assert (out / "images" / "front" / "render_+2.00").is_dir()
    assert main(["synth", str(out), *CLIP]) == 0
    assert not (out / "images" / "front" / "render_+2.00").exists()  # no orphaned renders
    listed = set(pd.read_csv(out / "images.csv").path) | {"images.csv", "scene.json", "degradation.csv"}
    assert {p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()} == listed
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene"]  # no temporary folder left


def test_outputs_follow_the_umask(tmp_path):
    # issue 38 item 6: mkstemp/mkdtemp make 0600/0700 files; outputs get what open/mkdir would give
    old = os.umask(0o022)
    try:
        assert main(["synth", str(tmp_path / "scene"), *CLIP]) == 0
        assert main(["pairs", str(tmp_path / "scene"), "--out", str(tmp_path / "pairs.csv"), "--quiet",
                     "--min-side", "4"]) == 0
    finally:
        os.umask(old)
    for p in (tmp_path / "scene" / "scene.json", tmp_path / "scene" / "images.csv", tmp_path / "pairs.csv",
              tmp_path / "scene" / "degradation.csv"):
        assert stat.S_IMODE(p.stat().st_mode) == 0o644, p
    assert stat.S_IMODE((tmp_path / "scene").stat().st_mode) == 0o755


def test_kitti_import_over_a_synth_scene(shared_dir, tmp_path):
    kitti = shared_dir / "realdata" / "kitti"
    if not kitti.is_dir():
        pytest.skip("no KITTI frames in ../shared/realdata")
    out = tmp_path / "scene"
    assert main(["synth", str(out), *CLIP]) == 0
    assert main(["import", "kitti", str(kitti), "000000", str(out)]) == 0
    assert sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()) == [
        "images.csv", "images/000000.png", "scene.json"]
    shutil.rmtree(out)


def test_every_importer_reads_a_path_and_keywords():
    # issue 46 item 1: importers take ``read(path, **options)`` (the command turns its arguments
    # into the options), so a caller without argparse uses them as they are
    import importlib
    import inspect

    for command in imports.IMPORTERS:
        importer = importlib.import_module(command.module).IMPORTER
        assert isinstance(importer, Importer)
        params = list(inspect.signature(importer.read).parameters.values())
        assert params[0].name == "path" and params[0].kind is inspect.Parameter.POSITIONAL_OR_KEYWORD, command.name
        assert all(p.kind in (inspect.Parameter.KEYWORD_ONLY, inspect.Parameter.VAR_KEYWORD) for p in params[1:]), \
            command.name
