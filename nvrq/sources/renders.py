"""Register a renderer's output in a scene folder (``nvrq import renders``, docs/FORMATS.md §14).

The renders are those of the scene's render plan, :func:`nvrq.render_plans.render_plan`
``(scene, method=method)``: what ``nvrq render-plan SCENE [--method NAME]`` writes (the views
``images.csv`` lists, every camera), row by row in the plan's order. ``DIR`` holds them in
one of two layouts:

``plan``
    The file of each row at the row's ``path`` under ``DIR`` (``DIR/images/front/render_+1.00/
    100000.png``): a renderer that writes where the plan says, with ``DIR`` as its root.
``order``
    The file of row ``i`` (0-based, in plan order) directly in ``DIR``, named ``{i:05d}`` plus
    ``.png``, ``.jpg`` or ``.jpeg`` (any case): ``00000.png``, ``00001.png``, ...,
    ``99999.png``, ``100000.png``, as ``ns-render`` and most scripts number their frames. Any
    other name (``0001.png``, ``000001.png``, ``frame_1.png``) is not a render of the plan.

Files and folders whose names start with ``.`` are ignored. Every other file of ``DIR`` (at any
depth for ``plan``, directly in ``DIR`` for ``order``) that is no row's render is *unexpected*.
Each render must be an image that ``nvrq score`` can read (:func:`nvrq.crops.read_rgb`) of its
camera's size. The import fails, having changed nothing, on any unexpected file, unreadable
file or wrong size, on a missing render unless ``allow_missing`` (then those views get no
render row, so ``nvrq pairs`` leaves them out), and when no render is found at all.

The renders are copied (or, with ``link``, symbolically linked: absolute links to the files
in ``DIR``) into the scene at the plan's paths, with the suffix of the file found (a
``00003.jpg`` for ``.../100000.png`` lands at ``.../100000.jpg``); the user's files are never
moved. ``images.csv`` is rewritten: each render row of the plan points at its file, rows of
missing renders are removed. The files and ``images.csv`` are first staged in the scene's
``.nvrq-import/`` folder, then swapped in (:mod:`nvrq.sources.render_swap`): a kill before the
swap leaves the scene as it was, a kill during it leaves a journal that the next import
finishes first, so running the same import again gives the scene an uninterrupted one gives.

Methods (``method``, docs/FORMATS.md §2): a named method's renders go to its plan paths
(``render_<view>/<method>/...`` unless images.csv lists others), so several methods fill one
scene. A scene holds one unnamed method or named ones, never both:

- into a scene whose renders name methods, every import names one (a new one is added, one it
  already holds is replaced);
- into a scene whose renders name none, an import without ``method`` fills them; one with
  ``method`` takes their place only while none of their files exists (the rows an importer
  lists for a renderer to fill); otherwise ``existing_method`` must first name them (their
  paths and files stay as they are).
"""

from __future__ import annotations

import dataclasses
import functools
import os
import re
import shutil
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from data_schema.errors import InputError
from data_schema.methods import METHOD_COLUMN, check_method_name, method_values
from data_schema.perturbation import PERTURBATION_COLUMNS, labels, perturbation_array
from data_schema.scene import load_scene, write_images
from data_schema.text import plural
from nvrq.choices import LAYOUTS  # the layouts of a folder of renders (module docstring)
from nvrq.crops import read_rgb
from nvrq.render_plans import RenderPlan, render_plan
from nvrq.sources.render_swap import finish_interrupted, stage_and_swap

__all__ = ["LAYOUTS", "ORDER_SUFFIXES", "MAX_WALK_DEPTH", "RendersImport", "import_renders", "render_files"]

#: File suffixes of the ``order`` layout (compared in lower case).
ORDER_SUFFIXES = (".png", ".jpg", ".jpeg")
_ORDER_NAME = re.compile(r"(\d{5,})(\.[A-Za-z]+)")


@dataclass(frozen=True)
class RendersImport:
    """What :func:`import_renders` did: ``expected`` plan rows, ``imported`` renders, the
    plan rows whose render was ``missing`` (their plan paths) and the ``unexpected`` files
    (relative to the folder of renders; always empty after a successful import); ``missing`` names
    the file to supply, ``{i:05d}.png (for PLAN PATH)`` in the ``order`` layout; ``changed``: the
    render files already in the scene that the import replaced with other bytes or removed.

    Attributes
    ----------
    images_csv : pathlib.Path
        The scene's ``images.csv``.
    layout : str
        The renders' layout (``plan`` or ``order``).
    method : str
        The method the renders belong to.
    expected : int
        Number of plan rows.
    imported : int
        Number of renders imported.
    missing : tuple of str
        The plan rows whose render is missing (the file to supply).
    unexpected : tuple of str
        Files in the folder of renders that match no plan row.
    changed : int
        Render files already in the scene that were replaced or removed (default 0).
    skipped : tuple of str
        Folders of the folder of renders not walked: links into a loop, or deeper than
        :data:`MAX_WALK_DEPTH` (default none).
    recovered : str
        ``'finished'`` or ``'discarded'`` when an interrupted import was found first
        (:func:`nvrq.sources.render_swap.finish_interrupted`), else ``''``.
    """

    images_csv: Path
    layout: str
    method: str
    expected: int
    imported: int
    missing: tuple[str, ...]
    unexpected: tuple[str, ...]
    changed: int = 0
    skipped: tuple[str, ...] = ()
    recovered: str = ""

    def counts(self) -> str:
        """``'N expected, F found, M missing, U unexpected'`` with the first of each kind."""
        found = self.expected - len(self.missing)
        text = f"{self.expected} expected, {found} found, {len(self.missing)} missing, {len(self.unexpected)} unexpected"
        if self.skipped:
            text += f", {len(self.skipped)} linked folders not walked (a link loop or too deep)"
        firsts = [f"first {kind}: {items[0]}" for kind, items in (("missing", self.missing),
                                                                   ("unexpected", self.unexpected),
                                                                   ("not walked", self.skipped)) if items]
        return text + (f" ({'; '.join(firsts)})" if firsts else "")

    def summary(self) -> str:
        """One line for the command: the counts and where the rows went."""
        named = f" of method {self.method}" if self.method else ""
        left = " (missing views left out of the pairs)" if self.missing else ""
        changed = f"; replaced: {plural(self.changed, 'render file')} changed" if self.changed else ""
        first = {"finished": "an interrupted import was finished first; ",
                 "discarded": "the staged files of an interrupted import were discarded first; "}.get(self.recovered, "")
        return f"{first}renders{named}, layout {self.layout}: {self.counts()}{left}{changed} -> {self.images_csv}"


#: the deepest folder level the ``plan`` layout walks (a plan path is a few levels deep)
MAX_WALK_DEPTH = 32


def _visible_files(folder: Path, *, recursive: bool, skipped: list | None = None) -> list[str]:
    """POSIX paths (relative to ``folder``) of its files, names starting with ``.`` aside.

    The walk follows links to folders, but never into a folder that holds the link (its
    ``(st_dev, st_ino)`` is one of the walk's current folders: a link loop) nor deeper than
    :data:`MAX_WALK_DEPTH` levels; such folders are appended to ``skipped`` (relative paths)."""
    if not recursive:
        return sorted(e.name for e in os.scandir(folder) if not e.name.startswith(".") and e.is_file())
    out: list[str] = []
    skipped = [] if skipped is None else skipped
    st = os.stat(folder)
    stack = [(folder, Path("."), 0, frozenset({(st.st_dev, st.st_ino)}))]
    while stack:
        here, rel, depth, above = stack.pop()
        try:
            entries = sorted(os.scandir(here), key=lambda e: e.name)
        except OSError:
            skipped.append(rel.as_posix())
            continue
        subs = []
        for e in entries:
            if e.name.startswith("."):
                continue
            try:
                if e.is_dir():
                    est = e.stat()
                    key = (est.st_dev, est.st_ino)
                    if key in above or depth + 1 > MAX_WALK_DEPTH:
                        skipped.append((rel / e.name).as_posix())
                        continue
                    subs.append((Path(e.path), rel / e.name, depth + 1, above | {key}))
                elif e.is_file():
                    out.append((rel / e.name).as_posix())
            except OSError:  # a broken link or a link loop the OS refuses to resolve
                skipped.append((rel / e.name).as_posix())
        stack.extend(reversed(subs))
    return sorted(out)


def render_files(plan: RenderPlan, render_dir, *, layout: str = "plan",
                 skipped: list | None = None) -> tuple[list, list[str]]:
    """The file of each plan row in ``render_dir`` under ``layout`` (module docstring).

    Parameters
    ----------
    plan : RenderPlan
        The render plan.
    render_dir : str or os.PathLike
        The folder of renders.
    layout : str, optional
        ``plan`` (files at the plan paths, the default) or ``order``.
    skipped : list, optional
        Receives the folders the ``plan`` walk did not enter (links into a loop, or deeper
        than :data:`MAX_WALK_DEPTH`), relative paths.

    Returns
    -------
    files : list of str or None, one per plan row
        The render's path relative to ``render_dir`` (``None`` where it is missing).
    unexpected : list of str
        The other files (relative paths, sorted).

    Raises
    ------
    InputError
        An unknown layout, or (``order``) two files for one row.
    """
    _check_layout(layout)
    folder = Path(render_dir)
    present = _visible_files(folder, recursive=layout == "plan", skipped=skipped)
    if layout == "plan":
        have = set(present)
        files = [p if p in have else None for p in plan.paths]
        wanted = set(plan.paths)
        return files, [p for p in present if p not in wanted]
    files, unexpected = [None] * len(plan), []
    for name in present:
        m = _ORDER_NAME.fullmatch(name)
        i = int(m.group(1)) if m else -1
        if not m or m.group(2).lower() not in ORDER_SUFFIXES or m.group(1) != f"{i:05d}" or i >= len(plan):
            unexpected.append(name)
        elif files[i] is not None:
            raise InputError(folder, f"row {i}", "one file per plan row", f"{files[i]} and {name}")
        else:
            files[i] = name
    return files, unexpected


def _missing_name(plan: RenderPlan, i: int, layout: str) -> str:
    """The file the user must supply for plan row ``i``: its plan path (``plan``), or
    ``{i:05d}.png`` with the plan path it goes to (``order``)."""
    return plan.paths[i] if layout == "plan" else f"{i:05d}.png (for {plan.paths[i]})"


def _replaced(scene_root: Path, images: pd.DataFrame, new: pd.DataFrame, placed: dict) -> tuple[int, int]:
    """``(changed, on_disk)``: how many render files of the scene this import changes (a file of
    ``images`` on disk that gets other bytes, or whose row goes) and how many it finds on disk.

    ``placed``: scene path -> the file put there."""
    import filecmp

    old = set(images.path[(images.source == "render").to_numpy()])
    kept = set(new.path[(new.source == "render").to_numpy()])
    changed = on_disk = 0
    for rel in sorted(old):
        target = scene_root / rel
        if not target.is_file():
            continue
        on_disk += 1
        src = placed.get(rel)
        if src is None:
            changed += rel not in kept
        elif not (os.path.samefile(src, target) or filecmp.cmp(src, target, shallow=False)):
            changed += 1
    return changed, on_disk


def _check_layout(layout) -> None:
    if layout not in LAYOUTS:
        raise InputError(param="layout", expected="one of {" + ", ".join(map(repr, LAYOUTS)) + "}", got=repr(layout))


def _check_names(method, existing_method, layout) -> None:
    _check_layout(layout)
    for name, value in (("method", method), ("existing_method", existing_method)):
        if value is not None:
            check_method_name(value, where=name, field=None)


def _named_scene(scene, method: str | None, existing_method: str | None):
    """``(scene, placeholders)``: the scene with ``existing_method`` naming its unnamed renders,
    and the (N,) mask of the unnamed render rows that an import of ``method`` replaces
    (module docstring); errors for the combinations the method rules refuse."""
    images = scene.images.copy()
    where = scene.root / "images.csv"
    render = (images.source == "render").to_numpy()
    if not render.any():
        raise InputError(where, "column source", "render rows (the views to import renders of)", "none")
    names = sorted(set(method_values(images)[render]) - {""})
    if existing_method is not None:
        if names:
            raise InputError(param="existing_method", expected="a scene whose renders name no method", got="renders of " + ", ".join(names))
        images[METHOD_COLUMN] = np.where(render, existing_method, "")
        names = [existing_method]
    if not method and names:
        raise InputError(param="method", expected="a method name: the scene's renders name methods ("
                         + ", ".join(names) + ")", got="none")
    placeholders = np.zeros(len(images), bool)
    if method and not names:
        on_disk = [p for p in images.path[render] if (scene.root / p).is_file()]
        if on_disk:
            raise InputError(where, f"column {METHOD_COLUMN}",
                             "unnamed renders that are not on disk yet, to be replaced by a named method "
                             "(name the existing ones with existing_method first)",
                             f"{len(on_disk)} unnamed renders on disk, e.g. {on_disk[0]}")
        placeholders = render
    return dataclasses.replace(scene, images=images), placeholders


def _check_image(src: Path, width: int, height: int, camera: str) -> str | None:
    """Why ``src`` is no render of ``camera`` (its header read first, then decoded), or None."""
    try:
        read_rgb(src, size=(width, height), of=f"camera {camera}")
    except InputError as exc:
        return f"{exc.expected}, got {exc.got}" if exc.expected != "a readable image file" else str(exc.got)
    return None


def _check_images(srcs: list[Path], plan: RenderPlan, rows: list[int], folder: Path) -> None:
    """Every render readable and of its camera's size (:func:`nvrq.crops.read_rgb`: the header
    is checked before a pixel is decoded, so a decompression bomb costs nothing); decoded in
    threads; every bad file is named in one error, with their count."""
    with ThreadPoolExecutor(max_workers=min(8, os.cpu_count() or 1)) as pool:
        why = list(pool.map(lambda a: _check_image(*a), [(s, int(plan.widths[i]), int(plan.heights[i]),
                                                          plan.cameras[i]) for s, i in zip(srcs, rows, strict=True)]))
    bad = [(s, w) for s, w in zip(srcs, why, strict=True) if w is not None]
    if bad:
        listed = "; ".join(f"{os.path.relpath(s, folder)}: {w}" for s, w in bad)
        raise InputError(folder, f"renders ({listed})", "readable images of their camera's size",
                         f"{plural(len(bad), 'bad render file')} of {len(srcs)}")


def _same_file(src: Path, dst: Path) -> bool:
    return dst.exists() and os.path.samefile(src, dst)


def _put(src: Path, path: Path, *, link: bool) -> None:
    """Copy (or link: an absolute symbolic link) ``src`` to the staging path ``path``."""
    if link:
        os.symlink(src.resolve(), path)
    else:
        shutil.copyfile(src, path)


def _new_images(scene, plan: RenderPlan, placeholders, dst: dict, method: str) -> pd.DataFrame:
    """``images.csv`` after the import: placeholder rows gone; each planned render row of
    ``method`` pointing at its file (``dst``: plan row -> scene path), or gone when missing;
    rows of found renders not listed yet appended (then sorted by camera and time)."""
    images = scene.images
    keys = list(zip(images.camera, images.timestamp_us.astype(np.int64), labels(perturbation_array(images)),
                    method_values(images), strict=True))
    plan_keys = list(zip(plan.cameras, plan.timestamps_us, labels(plan.perturbations), plan.methods, strict=True))
    row_of = {k: i for i, k in enumerate(plan_keys)}
    render = (images.source == "render").to_numpy()
    keep = ~placeholders
    paths = images.path.to_numpy(dtype=object).copy()
    listed = set()
    for j, k in enumerate(keys):
        i = row_of.get(k)
        if not render[j] or placeholders[j] or i is None:
            continue
        listed.add(i)
        if i in dst:
            paths[j] = dst[i]
        else:
            keep[j] = False  # a missing render: the view leaves the pairs
    out = images.assign(path=paths)[keep]
    new = [i for i in dst if i not in listed]
    if not new:
        return out
    P = plan.perturbations[new]
    add = pd.DataFrame({"camera": plan.cameras[new], "timestamp_us": plan.timestamps_us[new], "source": "render",
                        **{c: P[:, j] for j, c in enumerate(PERTURBATION_COLUMNS)}, "path": [dst[i] for i in new]})
    if method:
        add[METHOD_COLUMN] = method
    out = pd.concat([out, add], ignore_index=True)
    if METHOD_COLUMN in out.columns:
        out[METHOD_COLUMN] = method_values(out)
    order = {c: n for n, c in enumerate(scene.cameras)}
    out = out.assign(_cam=out.camera.map(order)).sort_values(["_cam", "timestamp_us"], kind="stable")
    return out.drop(columns="_cam").reset_index(drop=True)


def import_renders(scene, render_dir, *, method: str | None = None, layout: str = "plan",
                   allow_missing: bool = False, link: bool = False,
                   existing_method: str | None = None, replace: bool = False) -> RendersImport:
    """Register the renders in ``render_dir`` in the scene folder ``scene`` (module docstring).

    Parameters
    ----------
    scene : path
        The scene folder; its ``images.csv`` must list render rows (the views to import).
    render_dir : path
        The folder of renders, in ``layout``; not the scene folder itself.
    method : str, optional
        The method of these renders (the ``method`` column, docs/FORMATS.md §2).
    layout : {'plan', 'order'}
        Where each plan row's render lies in ``render_dir``.
    allow_missing : bool
        Leave views without a render out of the scene instead of failing.
    link : bool
        Link the files (absolute symbolic links) instead of copying them.
    existing_method : str, optional
        First name the scene's unnamed renders so (their paths and files stay).
    replace : bool
        Allow the import to change render files of this method already in the scene (other
        bytes at a path, or a row removed); without it such an import is refused, since the
        pairs and metrics made from them would go stale. Re-importing the same files changes
        nothing and needs no ``replace``.

    Returns
    -------
    RendersImport
        The counts.

    Raises
    ------
    InputError
        Bad names or layout; a scene without render rows; a method the method rules refuse;
        an unexpected, unreadable or wrongly sized file; a missing render (unless
        ``allow_missing``); no render found; render files of the method already in the scene
        that would change, without ``replace``. Nothing is changed then.
    """
    _check_names(method, existing_method, layout)
    folder = Path(render_dir)
    if not folder.is_dir():
        raise InputError(folder, None, "a folder of renders", "no such folder")
    recovered = finish_interrupted(scene) if Path(scene).is_dir() else None
    scene = load_scene(scene, check_images=False)
    if folder.resolve() == scene.root.resolve():
        raise InputError(param="render_dir", expected="a folder of renders other than the scene folder", got=str(folder))
    scene, placeholders = _named_scene(scene, method, existing_method)
    plan = render_plan(scene, method=method)
    skipped: list[str] = []
    files, unexpected = render_files(plan, folder, layout=layout, skipped=skipped)
    rows = [i for i, f in enumerate(files) if f is not None]
    report = RendersImport(scene.root / "images.csv", layout, method or "", len(plan), len(rows),
                           tuple(_missing_name(plan, i, layout) for i, f in enumerate(files) if f is None),
                           tuple(unexpected), skipped=tuple(skipped))
    if unexpected or not rows or (report.missing and not allow_missing):
        rule = "every render of the plan" if not allow_missing else "renders of the plan (some at least)"
        hint = (" (or `allow_missing` to leave the views without a render out)"
                if report.missing and rows and not unexpected and not allow_missing else "")
        raise InputError(folder, f"layout {layout}", f"{rule} and no other file{hint}", report.counts())
    srcs = [folder / files[i] for i in rows]
    _check_images(srcs, plan, rows, folder)
    dst = {}
    for i, src in zip(rows, srcs, strict=True):
        path = Path(plan.paths[i])
        same = src.suffix.lower() == path.suffix.lower()
        dst[i] = plan.paths[i] if same else path.with_suffix(src.suffix.lower()).as_posix()
        if (scene.root / dst[i]).is_dir():
            raise InputError(scene.root / dst[i], None, "a render file path", "an existing folder")
    images = _new_images(scene, plan, placeholders, dst, method or "")
    mine = scene.images[(method_values(scene.images) == (method or "")) | placeholders]
    changed, _ = _replaced(scene.root, mine, images, {dst[i]: src for i, src in zip(rows, srcs, strict=True)})
    if changed and not replace:
        named = f"method {method}'s" if method else "the scene's"
        raise InputError(param="replace", expected=f"`replace` to change {named} renders already in the scene "
                         "(pairs and metrics made from them go stale)", got=f"{plural(changed, 'render file')} that would change")
    put = {dst[i]: functools.partial(_put, src, link=link) for i, src in zip(rows, srcs, strict=True)
           if not _same_file(src, scene.root / dst[i])}
    stage_and_swap(scene.root, put, functools.partial(write_images, images))  # stage, then swap
    return dataclasses.replace(report, changed=changed, recovered=recovered or "")
