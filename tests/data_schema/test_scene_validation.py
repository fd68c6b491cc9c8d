"""Every validation error of the scene folder (issue 2 item 2): exit status 2 and a one-line message.

Each case starts from a valid scene and breaks one thing; the expected message fragments
are the ones docs/FORMATS.md §7 asks for (file, field, what was expected).
"""

from __future__ import annotations

import copy
import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from data_schema.errors import InputError
from data_schema.scene import load_scene, save_scene
from nvrq.cli import main

_spec = importlib.util.spec_from_file_location(
    "scene_validation_world", Path(__file__).resolve().parents[1] / "malformed" / "malformed_world.py")
_world = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_world)


def valid_doc() -> dict:
    """A valid scene.json: the malformed corpus's (one pinhole camera, two frames, one track)."""
    return _world.scene_doc()


def valid_images() -> pd.DataFrame:
    return pd.DataFrame({"camera": ["front", "front"], "timestamp_us": [0, 0], "source": ["gt", "render"],
                         "y_offset_m": [0.0, 1.0], "path": ["gt.png", "r.png"]})


def write(tmp_path, doc, images=None):
    images = valid_images() if images is None else images
    save_scene(doc, images, tmp_path)
    for p in ("gt.png", "r.png"):
        (tmp_path / p).write_bytes(_world._black_png())
    return tmp_path


def test_valid_scene_loads(tmp_path):
    scene = load_scene(write(tmp_path, valid_doc()))
    assert scene.clip_id == "clip" and list(scene.cameras) == ["front"]
    assert scene.T_rig_world.shape == (2, 4, 4) and scene.tracks[0].poses.shape == (2, 7)


def test_quaternions_are_normalised(tmp_path):
    doc = valid_doc()
    doc["tracks"][0]["poses"][0][3:] = [0, 0, 0, 2.0]
    scene = load_scene(write(tmp_path, doc))
    assert scene.tracks[0].poses[0, 3:].tolist() == [0, 0, 0, 1.0]


def _set(doc, path, value):
    _world.set_in(doc, path, value)


ROT_BAD = [[1, 0, 0, 0], [0, 1, 0.01, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
BOTTOM_BAD = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1]]

# (mutation path, new value, fragments the one-line message must contain)
DOC_CASES = {
    "missing key": (("clip_id",), KeyError, ["scene.json", "clip_id", "to be present"]),
    "wrong matrix shape": (("cameras", "front", "T_sensor_rig"), [[1, 0, 0, 0]] * 3,
                           ["cameras.front.T_sensor_rig", "4x4", "3x4"]),
    "not orthonormal": (("rig_trajectory", "T_rig_world", 1), ROT_BAD,
                        ["rig_trajectory.T_rig_world[1]", "orthonormal"]),
    "bottom row": (("cameras", "front", "T_sensor_rig"), BOTTOM_BAD, ["T_sensor_rig", "bottom row of 0 0 0 1"]),
    "timestamps not increasing": (("rig_trajectory", "timestamps_us"), [100000, 100000],
                                  ["rig_trajectory.timestamps_us[1]", "strictly increasing"]),
    "pose not 7 numbers": (("tracks", 0, "poses", 1), [16, 0, 0.8, 0, 0, 1],
                           ["tracks[0].poses[1]", "7 numbers"]),
    "zero quaternion": (("tracks", 0, "poses", 0), [15, 0, 0.8, 0, 0, 0, 1e-9],
                        ["tracks[0].poses[0]", "non-zero norm"]),
    "unknown camera model": (("cameras", "front", "model", "type"), "kannala",
                             ["cameras.front.model.type", "one of", "'kannala'"]),
    "missing model parameter": (("cameras", "front", "model", "focal_length"), KeyError,
                                ["cameras.front.model.focal_length", "pinhole parameter"]),
    "track timestamps vs poses": (("tracks", 0, "timestamps_us"), [0],
                                  ["tracks[0].poses", "1 poses"]),
}


@pytest.mark.parametrize("case", list(DOC_CASES))
def test_scene_json_errors(tmp_path, capsys, case):
    path, value, fragments = DOC_CASES[case]
    doc = copy.deepcopy(valid_doc())
    _set(doc, path, value)
    write(tmp_path, doc)
    rc = main(["pairs", str(tmp_path), "--out", str(tmp_path.with_name(tmp_path.name + "-p.csv"))])
    err = capsys.readouterr().err
    assert rc == 2
    assert err.count("\n") == 1 and err.startswith("error: ")
    for frag in fragments:
        assert frag in err, (frag, err)
    assert not (tmp_path.with_name(tmp_path.name + "-p.csv")).exists()


def _images(**changes):
    df = valid_images()
    for col, val in changes.items():
        df.loc[1, col] = val
    return df


IMAGE_CASES = {
    "unknown camera": (_images(camera="rear"), ["images.csv", "row 3, column camera", "'rear'"]),
    "bad source": (_images(source="nerf"), ["row 3, column source", "'gt' or 'render'"]),
    "missing file": (_images(path="nope.png"), ["row 3, column path", "existing image file", "nope.png"]),
    "absolute path": (_images(path="/etc/passwd"), ["row 3, column path", "inside the scene folder"]),
    "dotdot path": (_images(path="../x.png"), ["row 3, column path", "inside the scene folder"]),
    "missing column": (valid_images().drop(columns=["source"]), ["images.csv", "column 'source'"]),
}


@pytest.mark.parametrize("case", list(IMAGE_CASES))
def test_images_csv_errors(tmp_path, capsys, case):
    images, fragments = IMAGE_CASES[case]
    save_scene(valid_doc(), valid_images(), tmp_path)
    images.to_csv(tmp_path / "images.csv", index=False)
    for p in ("gt.png", "r.png"):
        (tmp_path / p).write_bytes(_world._black_png())
    rc = main(["pairs", str(tmp_path), "--out", str(tmp_path.with_name(tmp_path.name + "-p.csv"))])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1
    for frag in fragments:
        assert frag in err, (frag, err)


def test_missing_and_invalid_scene_json(tmp_path, capsys):
    assert main(["pairs", str(tmp_path / "nowhere"), "--out", str(tmp_path.with_name(tmp_path.name + "-p.csv"))]) == 2
    assert "expected a scene folder" in capsys.readouterr().err
    (tmp_path / "scene.json").write_text("{not json")
    assert main(["pairs", str(tmp_path), "--out", str(tmp_path.with_name(tmp_path.name + "-p.csv"))]) == 2
    err = capsys.readouterr().err
    assert "scene.json" in err and "valid JSON" in err


def test_images_may_be_absent_when_not_checked(tmp_path):
    save_scene(valid_doc(), valid_images(), tmp_path)
    with pytest.raises(InputError, match="existing image file"):
        load_scene(tmp_path)
    assert len(load_scene(tmp_path, check_images=False).images) == 2


def test_console_script_exit_status(tmp_path):
    """The installed entry point (not only main()) exits 2 with one stderr line."""
    doc = valid_doc()
    doc["cameras"]["front"]["model"]["type"] = "kannala"
    write(tmp_path, doc)
    proc = subprocess.run([sys.executable, "-m", "nvrq", "pairs", str(tmp_path), "--out", str(tmp_path.with_name(tmp_path.name + "-p.csv"))],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0 and "model.type" in proc.stderr
    assert json.loads((tmp_path / "scene.json").read_text())["format"] == "nvrq-scene"


def test_symlinked_image_folders_checked_per_load(tmp_path):
    """Under the strict link rule (follow_links=False, docs/FORMATS.md §7) a folder symlink is
    checked once per distinct folder and load (not cached across loads): one that stays inside
    the scene is accepted, one that leaves it is refused on every row. By default both load."""
    scene, outside = tmp_path / "scene", tmp_path / "outside"
    (scene / "real").mkdir(parents=True)
    outside.mkdir()
    for d in (scene / "real", outside):
        for p in ("gt.png", "r.png"):
            (d / p).write_bytes(_world._black_png())
    images = valid_images().assign(path=["img/gt.png", "img/r.png"])
    save_scene(valid_doc(), images, scene)
    (scene / "img").symlink_to(scene / "real")
    assert len(load_scene(scene, follow_links=False).images) == 2
    (scene / "img").unlink()
    (scene / "img").symlink_to(outside)
    with pytest.raises(InputError) as exc:
        load_scene(scene, follow_links=False)
    assert str(exc.value) == (f"{scene / 'images.csv'}: row 2, column path: expected a file inside the "
                              "scene folder (a symlink leaves it, and links are not followed: "
                              "`no_follow_links` or NVRQ_NO_FOLLOW_LINKS=1), got img/gt.png")
    assert len(load_scene(scene).images) == 2  # followed by default
    (scene / "img").unlink()
    (scene / "img").mkdir()
    for p in ("gt.png", "r.png"):
        (scene / "img" / p).symlink_to(outside / p)
    with pytest.raises(InputError, match="symlink leaves it"):
        load_scene(scene, follow_links=False)
    assert len(load_scene(scene).images) == 2
