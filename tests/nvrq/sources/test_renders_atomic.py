"""``nvrq import renders --replace`` killed at any moment (SIGKILL, no clean-up) never leaves a
half-replaced scene that can be read, and running the same import again gives byte for byte the
scene an uninterrupted import gives.

The import runs in a forked child (the parent's modules already loaded, so a kill point costs a
fraction of a second) and is killed two ways: by a hook that sends the child SIGKILL at its n-th
file operation (every copy and rename: staging, the commit, each swap), and by the parent after
a random delay."""

from __future__ import annotations

import hashlib
import os
import shutil
import signal
import time
import warnings
from pathlib import Path

import cv2
import numpy as np
import pytest

from data_schema.errors import InputError
from data_schema.scene import IMPORT_STAGING, load_scene
from nvrq.cli import main
from nvrq.render_plans import render_plan

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="needs os.fork")


def _snapshot(root: Path) -> dict[str, str]:
    out = {}
    for dirpath, _, files in os.walk(root):
        for f in files:
            p = Path(dirpath) / f
            out[str(p.relative_to(root))] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    """A scene with renders, a folder of other renders for every view, and the scene an
    uninterrupted ``--replace`` import of them gives."""
    d = tmp_path_factory.mktemp("atomic")
    assert main(["synth", str(d / "scene"), "--seconds", "1", "--fps", "5", "--size", "160x90",
                 "--offsets=-1,1", "--quiet"]) == 0
    plan = render_plan(d / "scene")
    for p in plan.paths:  # every render changes
        (d / "new" / p).parent.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(d / "new" / p), 255 - cv2.imread(str(d / "scene" / p)))
    shutil.copytree(d / "scene", d / "ref")
    t0 = time.perf_counter()
    assert main(["import", "renders", str(d / "ref"), str(d / "new"), "--replace"]) == 0
    seconds = time.perf_counter() - t0
    assert not (d / "ref" / IMPORT_STAGING).exists()
    return d, _snapshot(d / "scene"), _snapshot(d / "ref"), seconds, len(plan.paths)


def _child(scene: Path, new: Path, kill_at: int | None) -> None:
    """The import in this (forked) process; with ``kill_at``, SIGKILL at that file operation."""
    if kill_at is not None:
        count = [0]
        real_copy, real_replace = shutil.copyfile, os.replace

        def tick():
            count[0] += 1
            if count[0] == kill_at:
                os.kill(os.getpid(), signal.SIGKILL)

        def copyfile(*a, **k):
            tick()
            return real_copy(*a, **k)

        def replace(*a, **k):
            tick()
            return real_replace(*a, **k)

        shutil.copyfile, os.replace = copyfile, replace
    from nvrq.sources.renders import import_renders

    import_renders(scene, new, replace=True)


def _fork(scene: Path, new: Path, *, kill_at: int | None = None, delay: float | None = None) -> int:
    """Run the import in a child; returns its wait status's signal (0: it finished)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # fork with threads (Python >= 3.12)
        pid = os.fork()
    if pid == 0:
        code = 1
        try:
            _child(scene, new, kill_at)
            code = 0
        finally:
            os._exit(code)
    if delay is not None:
        time.sleep(delay)
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    _, status = os.waitpid(pid, 0)
    if os.WIFSIGNALED(status):
        return os.WTERMSIG(status)
    assert os.WEXITSTATUS(status) == 0
    return 0


def _check_after_kill(scene: Path, before: dict, after: dict) -> str:
    """The killed scene is the old one, or refused until the import is run again; returns which."""
    visible = {k: v for k, v in _snapshot(scene).items() if not k.startswith(IMPORT_STAGING + os.sep)}
    try:
        load_scene(scene)
    except InputError as exc:  # killed while swapping: the journal says so, nothing reads it
        assert "interrupted" in str(exc) and (scene / IMPORT_STAGING / "journal.json").is_file()
        return "journal"
    if visible == before:
        return "old"
    assert visible == after, "a readable scene that is neither the old one nor the new one"
    return "new"


def _rerun_gives_the_reference(scene: Path, new: Path, after: dict, capsys) -> str:
    capsys.readouterr()
    assert main(["import", "renders", str(scene), str(new), "--replace"]) == 0
    out = capsys.readouterr().out
    assert _snapshot(scene) == after  # byte for byte, and no staging folder left
    return out


def test_a_kill_at_every_file_operation_then_a_rerun_gives_the_uninterrupted_scene(world, tmp_path, capsys):
    d, before, after, _, n = world
    # n copies, then the staged images.csv's and the journal's renames, then n + 1 swaps
    ops = 2 * n + 3
    seen = set()
    for k in range(1, ops + 2):
        scene = tmp_path / f"s{k}"
        shutil.copytree(d / "scene", scene)
        sig = _fork(scene, d / "new", kill_at=k)
        assert sig == (signal.SIGKILL if k <= ops else 0), (k, sig)
        state = _check_after_kill(scene, before, after)
        seen.add(state)
        out = _rerun_gives_the_reference(scene, d / "new", after, capsys)
        if state == "journal":
            assert out.startswith("an interrupted import was finished first; ")
        shutil.rmtree(scene)
    assert seen == {"old", "journal", "new"}  # before the commit, during the swap, after the last step


def test_random_sigkills_then_a_rerun_give_the_uninterrupted_scene(world, tmp_path, capsys):
    d, before, after, seconds, _ = world
    rng = np.random.default_rng(44)
    for k, delay in enumerate(rng.uniform(0, 1.5 * seconds, 6)):
        scene = tmp_path / f"r{k}"
        shutil.copytree(d / "scene", scene)
        _fork(scene, d / "new", delay=float(delay))
        _check_after_kill(scene, before, after)
        _rerun_gives_the_reference(scene, d / "new", after, capsys)
        shutil.rmtree(scene)


def test_a_staging_folder_without_journal_is_discarded_and_the_scene_was_untouched(world, tmp_path, capsys):
    d, before, after, _, _ = world
    scene = tmp_path / "s"
    shutil.copytree(d / "scene", scene)
    (scene / IMPORT_STAGING / "files").mkdir(parents=True)
    (scene / IMPORT_STAGING / "files" / "half.png").write_bytes(b"\x89PNG")
    assert load_scene(scene) is not None  # readable: the scene itself is the old one
    out = _rerun_gives_the_reference(scene, d / "new", after, capsys)
    assert out.startswith("the staged files of an interrupted import were discarded first; ")
