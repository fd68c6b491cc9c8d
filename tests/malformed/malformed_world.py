"""Helpers of the malformed-input corpus (issue 13): valid inputs of every kind, snapshots.

``build_world`` writes a folder of valid inputs of every kind: a scene folder with ``scene.json``, a toy
scene + pairs table with real images, a metrics table, a study with simulated votes and its
exported ratings. Each case copies what it breaks into its own folder and refers to the rest
of ``world`` read-only; ``test_world_untouched`` checks at the end that no case wrote into it.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import shutil
from pathlib import Path

import numpy as np

_spec = importlib.util.spec_from_file_location(
    "malformed_toy", Path(__file__).resolve().parents[1] / "annotate" / "toy.py")
toy = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(toy)


def scene_doc() -> dict:
    """A valid scene.json (one pinhole camera, two frames, one track)."""
    T = [[0, 0, 1, 0], [-1, 0, 0, 0], [0, -1, 0, 1.5], [0, 0, 0, 1]]
    from data_schema.scene import FORMAT, VERSION

    return {
        "format": FORMAT, "version": VERSION, "clip_id": "clip",
        "attributes": {"lighting": "daytime", "road_type": "urban"},
        "cameras": {"front": {"T_sensor_rig": T, "model": {
            "type": "pinhole", "resolution": [640, 480], "focal_length": [500.0, 500.0],
            "principal_point": [319.5, 239.5]}}},
        "rig_trajectory": {"timestamps_us": [0, 100000],
                           "T_rig_world": [np.eye(4).tolist(), np.eye(4).tolist()]},
        "tracks": [{"track_id": "car-1", "label_class": "automobile", "dims_lwh": [4.5, 1.9, 1.6],
                    "timestamps_us": [0, 100000],
                    "poses": [[15, 0, 0.8, 0, 0, 0, 1], [16, 0, 0.8, 0, 0, 0, 1]]}],
    }


def set_in(doc: dict, path: tuple, value) -> None:
    """Set ``doc[path[0]][path[1]]...`` to ``value``; ``value is KeyError`` deletes that key."""
    obj = doc
    for k in path[:-1]:
        obj = obj[k]
    if value is KeyError:
        del obj[path[-1]]
    else:
        obj[path[-1]] = value


IMAGES_CSV = ("camera,timestamp_us,source,y_offset_m,path\n"
              "front,0,gt,0.0,gt.png\nfront,0,render,1.0,r.png\n")


def write_scene(root: Path, doc: dict | None = None, images: str = IMAGES_CSV) -> Path:
    root.mkdir(parents=True, exist_ok=True)
    (root / "scene.json").write_text(json.dumps(scene_doc() if doc is None else doc))
    (root / "images.csv").write_text(images)
    for p in ("gt.png", "r.png"):
        (root / p).write_bytes(_black_png())
    return root


def _black_png(size=(640, 480)) -> bytes:
    """A black PNG of the scene's camera resolution (scene images are checked from their header)."""
    import cv2

    return cv2.imencode(".png", np.zeros((size[1], size[0], 3), np.uint8))[1].tobytes()


def snapshot(root: Path) -> dict[str, str]:
    """``{relative path: sha256}`` of every file under ``root`` (links as their target text)."""
    out = {}
    for dirpath, _, files in os.walk(root):
        for f in files:
            if f.endswith(("-wal", "-shm")):
                continue  # SQLite's transient companions of an open database
            p = Path(dirpath) / f
            key = str(p.relative_to(root))
            out[key] = ("link:" + os.readlink(p)) if p.is_symlink() else \
                hashlib.sha256(p.read_bytes()).hexdigest()
    return out




def copy_into(world: Path, name: str, dest: Path) -> Path:
    """Copy ``world/name`` (file or folder) to ``dest/name``; returns the copy."""
    src, dst = world / name, dest / name
    if src.is_dir():
        shutil.copytree(src, dst, ignore=shutil.ignore_patterns("*-wal", "*-shm"))
    else:
        dst.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, dst)
    return dst
