"""Set metrics per view: Fréchet distance and KID of render features against GT features
(library layer; ``nvrq score-sets``, docs/FORMATS.md §3c).

- :func:`embed`: features (n, d) of images from any encoder of the registry.
- :func:`frechet_distance`: ``|mu_r - mu_g|^2 + tr(S_r) + tr(S_g) - 2 tr((S_r S_g)^(1/2))`` with
  ``scipy.linalg.sqrtm``; the imaginary residue of the square root and a negative result are
  returned as they are, never hidden. Needs more samples than feature dimensions on both sides
  (below that the covariance is singular).
- :func:`kid`: the unbiased MMD² with the cubic polynomial kernel
  ``k(x, y) = (x.y / d + 1)^3``, averaged over random subsets (torch-fidelity's defaults:
  subset size ``min(1000, n)``, 100 subsets, seed 2020), with its standard deviation.
- :func:`score_sets`: both per set of a scene: ``frames`` (every render of one method and view
  against the GT frames of the same cameras and times, neurad-studio's lane-shift protocol) and
  ``objects`` (the render crops of one method and view against their GT crops).
- :func:`save_crop_features` / :func:`crop_features`: the crop embeddings ``nvrq score`` made
  (``--save-crop-features``), which ``score-sets --crop-features`` takes instead of embedding
  the same crops again: the same crop (file and box), the same input (square pad), the same
  encoder, runtime, precision, device and weights, so the same numbers.

>>> rng = np.random.default_rng(0)
>>> a = rng.normal(size=(50, 3))
>>> round(frechet_distance(a, a)["fd"], 9), round(frechet_distance(a, a + 1)["fd"], 9)
(0.0, 3.0)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from data_schema.defaults import MIN_VISIBLE
from data_schema.errors import InputError
from nvrq.choices import KID_SUBSET_SIZE, KID_SUBSETS, MAX_KID_SUBSET_SIZE, MAX_KID_SUBSETS

__all__ = ["embed", "frechet_distance", "kid", "SetOptions", "set_groups", "score_sets", "set_table",
           "encoder_identity", "save_crop_features", "crop_features",
           "KID_SUBSETS", "KID_SUBSET_SIZE", "KID_SEED", "MAX_KID_SUBSETS", "MAX_KID_SUBSET_SIZE"]

KID_SEED = 2020  # torch-fidelity's default rng_seed


def embed(images, *, encoder=None, batch_size: int = 32, square: str = "pad") -> np.ndarray:
    """Features of images from an encoder of the registry.

    Parameters
    ----------
    images : sequence of numpy.ndarray
        uint8 RGB images or crops (H, W, 3), any size.
    encoder : str, EncoderConfig or Encoder, optional
        A registry name (default ``efficientnet-lite0``, offline), a config, or a loaded encoder.
    batch_size : int, optional
        Images per forward pass.
    square : {'pad', 'stretch'}, optional
        How an image becomes the encoder's square input: centred on a black square (crops, as
        ``nvrq score``) or resized to it (whole frames, as FID implementations do).

    Returns
    -------
    numpy.ndarray
        (n, d) float64 features (GAP of the final tokens, :mod:`nvrq.encoders.registry`).
    """
    from nvrq.api import as_rgb_uint8
    from nvrq.crops import encoder_input, resize_to

    enc = _loaded(encoder)
    s = enc.spec.input_size
    prep = (lambda x: encoder_input(x, s)) if square == "pad" else (lambda x: resize_to(x, s, s))
    out = []
    items = list(images)
    for b0 in range(0, len(items), batch_size):
        batch = np.stack([prep(as_rgb_uint8(x, name=f"images[{b0 + k}]"))
                          for k, x in enumerate(items[b0:b0 + batch_size])])
        out.append(np.asarray(enc.embed(batch), np.float64))
    return np.concatenate(out) if out else np.zeros((0, 0))


def frechet_distance(render: np.ndarray, gt: np.ndarray) -> dict:
    """Fréchet distance between Gaussians fitted to two feature sets.

    Parameters
    ----------
    render, gt : numpy.ndarray
        (n_r, d) and (n_g, d) features; each needs ``n > d``.

    Returns
    -------
    dict
        ``fd`` (float, may be slightly negative from rounding), ``fd_residue``: the largest
        ``|imag|`` of the matrix square root (0 when it is real), both as computed.

    Raises
    ------
    InputError
        A set with ``n <= d`` (singular covariance) or sets of different ``d``.
    """
    from scipy import linalg

    r, g = np.asarray(render, np.float64), np.asarray(gt, np.float64)
    if r.ndim != 2 or g.ndim != 2 or r.shape[1] != g.shape[1]:
        raise InputError(param="features", expected="two (n, d) arrays of one d", got=f"{r.shape} and {g.shape}")
    d = r.shape[1]
    for name, x in (("render", r), ("gt", g)):
        if len(x) <= d:
            raise InputError(param=f"{name} features", expected=f"more samples than the {d} feature dimensions "
                             "for FD (the covariance is singular below)", got=f"{len(x)} samples")
    mu = r.mean(axis=0) - g.mean(axis=0)
    s_r, s_g = np.cov(r, rowvar=False), np.cov(g, rowvar=False)
    root = linalg.sqrtm(s_r @ s_g)
    residue = float(np.abs(np.imag(root)).max()) if np.iscomplexobj(root) else 0.0
    fd = float(mu @ mu + np.trace(s_r) + np.trace(s_g) - 2.0 * np.trace(np.real(root)))
    return {"fd": fd, "fd_residue": residue}


def kid(render: np.ndarray, gt: np.ndarray, *, subsets: int = KID_SUBSETS, subset_size: int = KID_SUBSET_SIZE,
        seed: int = KID_SEED) -> dict:
    """Kernel Inception Distance (unbiased MMD², cubic polynomial kernel) over random subsets.

    Parameters
    ----------
    render, gt : numpy.ndarray
        (n_r, d) and (n_g, d) features, ``n >= 2`` each.
    subsets, subset_size, seed : int, optional
        torch-fidelity's defaults: 100 subsets of ``min(subset_size, n_r, n_g)`` rows drawn
        without replacement from each set, ``numpy.random.RandomState(seed)``. ``subsets`` in
        ``[1, MAX_KID_SUBSETS]``, ``subset_size`` in ``[2, MAX_KID_SUBSET_SIZE]``.

    Returns
    -------
    dict
        ``kid`` (mean over subsets), ``kid_std`` (their standard deviation, ddof 0),
        ``kid_subset_size`` (m) and ``reason``. When ``m`` is the size of both sets every
        subset is the same: ``kid`` is computed once, ``kid_std`` is NaN and ``reason`` says why.
    """
    from data_schema.errors import check_int

    check_int("subsets", subsets, low=1, high=MAX_KID_SUBSETS)
    check_int("subset_size", subset_size, low=2, high=MAX_KID_SUBSET_SIZE)
    r, g = np.asarray(render, np.float64), np.asarray(gt, np.float64)
    m = min(int(subset_size), len(r), len(g))
    if m < 2:
        raise InputError(param="features", expected="at least 2 samples per set for KID",
                         got=f"{len(r)} render and {len(g)} gt")
    gamma = 1.0 / r.shape[1]
    if m == len(r) == len(g):
        # every subset is the whole of both sets, in another order, and MMD² does not depend on
        # the order: one value, and no spread to give
        return {"kid": _mmd2(*_kernels(r, g, gamma), m), "kid_std": float("nan"), "kid_subset_size": m,
                "reason": "KID has no spread: every subset is the whole of both sets"}
    rng = np.random.RandomState(seed)
    whole = len(r) * len(r) + len(g) * len(g) + len(r) * len(g) <= _KERNEL_CELLS
    if whole:  # the kernel of every pair once; each subset reads its block of it
        krr, kgg, krg = _kernels(r, g, gamma)
    vals = np.empty(int(subsets))
    for k in range(int(subsets)):
        ix, iy = rng.choice(len(r), m, replace=False), rng.choice(len(g), m, replace=False)
        if whole:
            blocks = krr[np.ix_(ix, ix)], kgg[np.ix_(iy, iy)], krg[np.ix_(ix, iy)]
        else:
            blocks = _kernels(r[ix], g[iy], gamma)
        vals[k] = _mmd2(*blocks, m)
    return {"kid": float(vals.mean()), "kid_std": float(vals.std()), "kid_subset_size": m, "reason": ""}


#: the most kernel entries (float64) :func:`kid` keeps at once: about 400 MB
_KERNEL_CELLS = 50_000_000


def _kernels(x: np.ndarray, y: np.ndarray, gamma: float):
    """The cubic polynomial kernels ``k(x, x)``, ``k(y, y)``, ``k(x, y)`` of (n, d) and (m, d)."""
    return ((x @ x.T * gamma + 1.0) ** 3, (y @ y.T * gamma + 1.0) ** 3, (x @ y.T * gamma + 1.0) ** 3)


def _mmd2(kxx: np.ndarray, kyy: np.ndarray, kxy: np.ndarray, m: int) -> float:
    """The unbiased MMD² of one subset pair of size ``m`` from its (m, m) kernel blocks."""
    return float(((kxx.sum() - np.trace(kxx)) + (kyy.sum() - np.trace(kyy))) / (m * (m - 1))
                 - 2.0 * kxy.sum() / (m * m))


@dataclass(frozen=True)
class SetOptions:
    """What ``nvrq score-sets`` computes. ``kinds``: ``frames`` and/or ``objects``; ``metrics``:
    ``fd`` and/or ``kid`` (``fd`` alone makes a set too small for FD an error, with ``kid`` it
    gets KID only and a reason); ``min_side``: the pairs' smallest crop side (objects).

    Attributes
    ----------
    kinds : tuple of str
        ``frames`` and/or ``objects`` (default both).
    metrics : tuple of str
        ``fd`` and/or ``kid`` (default both).
    kid_subsets : int
        Number of KID subsets (default :data:`KID_SUBSETS`).
    kid_subset_size : int
        KID subset size (default :data:`KID_SUBSET_SIZE`).
    seed : int
        Seed of the KID subsets (default :data:`KID_SEED`).
    min_side : float
        Objects: the smallest crop side of a pair, in pixels (default 30).
    min_visible : float
        Objects: the pairs' visibility rule (default :data:`data_schema.tables.MIN_VISIBLE`, as
        ``nvrq pairs``; 0 is the paper's protocol).
    """

    kinds: tuple[str, ...] = ("frames", "objects")
    metrics: tuple[str, ...] = ("fd", "kid")
    kid_subsets: int = KID_SUBSETS
    kid_subset_size: int = KID_SUBSET_SIZE
    seed: int = KID_SEED
    min_side: float = 30
    min_visible: float = MIN_VISIBLE

    def __post_init__(self):
        from data_schema.errors import check_int, check_number

        check_int("kid_subsets", self.kid_subsets, low=1, high=MAX_KID_SUBSETS)
        check_int("kid_subset_size", self.kid_subset_size, low=2, high=MAX_KID_SUBSET_SIZE)
        check_int("seed", self.seed, low=0, high=2**32 - 1)
        check_number("min_side", self.min_side, low=0)
        check_number("min_visible", self.min_visible, low=0, high=1)


def set_groups(scene, options: SetOptions, *, pairs: pd.DataFrame | None = None) -> pd.DataFrame:
    """The images of every set of ``scene``: one row per (set, side, image or crop).

    Parameters
    ----------
    scene : data_schema.scene.Scene
    options : SetOptions
    pairs : pandas.DataFrame, optional
        The scene's pairs table (``nvrq pairs``, of this clip), for the object sets; default:
        made here with ``options.min_side`` and ``options.min_visible``.

    Returns
    -------
    pandas.DataFrame
        ``set_id`` (``KIND:METHOD:VIEW``), ``kind``, ``method``, the view columns, ``side``
        (``gt``/``render``), ``path`` (relative to the scene) and ``box`` (inclusive crop box,
        or None for a whole frame).
    """
    from data_schema.methods import METHOD_COLUMN, method_values
    from data_schema.perturbation import (
        LABEL_COLUMN,
        PERTURBATION_COLUMNS,
        labels,
        perturbation_array,
    )

    parts = []
    img = scene.images
    gt = img[img.source == "gt"].set_index(["camera", "timestamp_us"])["path"]
    r = img[img.source == "render"]
    if "frames" in options.kinds and len(r):
        key = pd.MultiIndex.from_arrays([r.camera, r.timestamp_us])
        has = key.isin(gt.index)
        rr = r[has]
        view = perturbation_array(rr)
        base = pd.DataFrame({"kind": "frames", "method": method_values(rr), **{c: view[:, i] for i, c in
                             enumerate(PERTURBATION_COLUMNS)}, LABEL_COLUMN: labels(view)})
        parts.append(base.assign(side="render", path=rr.path.to_numpy(), box=None))
        gpath = gt.reindex(pd.MultiIndex.from_arrays([rr.camera, rr.timestamp_us])).to_numpy()
        parts.append(base.assign(side="gt", path=gpath, box=None))
    if "objects" in options.kinds and len(r):
        from nvrq.pairs import make_pairs

        if pairs is None:
            pairs, _ = make_pairs(scene, min_side=options.min_side, min_visible=options.min_visible, progress=False)
        elif len(pairs) and (pairs["clip_id"].astype(str) != str(scene.clip_id)).any():
            raise InputError(param="pairs", expected=f"the pairs of the scene's clip {scene.clip_id}",
                             got=f"clip {pairs['clip_id'].astype(str).iloc[0]}")
        view = perturbation_array(pairs)
        base = pd.DataFrame({"kind": "objects", "method": method_values(pairs),
                             **{c: view[:, i] for i, c in enumerate(PERTURBATION_COLUMNS)},
                             LABEL_COLUMN: labels(view)})
        rbox = pairs[["r_x0", "r_y0", "r_x1", "r_y1"]].to_numpy(np.int64).tolist()
        gbox = pairs[["gt_x0", "gt_y0", "gt_x1", "gt_y1"]].to_numpy(np.int64).tolist()
        parts.append(base.assign(side="render", path=pairs.render_path.to_numpy(), box=rbox))
        parts.append(base.assign(side="gt", path=pairs.gt_path.to_numpy(), box=gbox))
    out = pd.concat(parts, ignore_index=True) if parts else pd.DataFrame()
    if out.empty:
        what = " and ".join(options.kinds)
        raise InputError(scene.root, "images.csv", f"renders with GT of the same camera and time ({what})",
                         "an empty set: no image to compare")
    out[METHOD_COLUMN] = out["method"].astype(str)
    out.insert(0, "set_id", out["kind"] + ":" + out["method"] + ":" + out[LABEL_COLUMN])
    return out.sort_values(["kind", "method", "y_offset_m", "set_id", "side"], kind="stable").reset_index(drop=True)


def set_table(groups: pd.DataFrame, features: np.ndarray, options: SetOptions, *, encoder: str,
              where: str = "sets", progress: bool = False) -> pd.DataFrame:
    """FD and KID of every set from the features of its rows.

    Parameters
    ----------
    groups : pandas.DataFrame
        :func:`set_groups` rows (``set_id``, ``side`` and the set's columns).
    features : numpy.ndarray
        (n, d) one feature row per row of ``groups``.
    options : SetOptions
    encoder : str
        The encoder's name, in the column names (``fd:NAME``, ``kid:NAME``).
    where : str, optional
        Named in errors.
    progress : bool, optional
        A progress bar over the sets.

    Returns
    -------
    pandas.DataFrame
        One row per set: ``set_id, kind, method``, the view columns, ``n_render, n_gt``, then
        ``fd:ENC, fd_residue:ENC`` and/or ``kid:ENC, kid_std:ENC, kid_subset_size``, and
        ``reason`` (why FD, KID or KID's spread is empty, ``; ``-separated: FD needs more images
        per side than the feature dimension, KID at least 2).
    """
    from tqdm.auto import tqdm

    from data_schema.perturbation import LABEL_COLUMN, PERTURBATION_COLUMNS

    rows = []
    d = features.shape[1]
    sets = groups.groupby("set_id", sort=False)
    for sid, g in tqdm(sets, total=sets.ngroups, desc="sets: FD and KID", unit="set", disable=not progress):
        idx = g.index.to_numpy()
        side = g["side"].to_numpy()
        fr, fg = features[idx[side == "render"]], features[idx[side == "gt"]]
        row = {c: g[c].iloc[0] for c in ("set_id", "kind", "method", *PERTURBATION_COLUMNS, LABEL_COLUMN)}
        row.update(n_render=len(fr), n_gt=len(fg), reason="")
        reasons = []
        if "fd" in options.metrics:
            if min(len(fr), len(fg)) > d:
                fd = frechet_distance(fr, fg)
                row[f"fd:{encoder}"], row[f"fd_residue:{encoder}"] = fd["fd"], fd["fd_residue"]
            elif "kid" not in options.metrics:
                raise InputError(where, f"set {sid}", f"more than {d} images per side for FD (the feature "
                                 "dimension of " + encoder + "; or add kid)", f"{len(fr)} render, {len(fg)} gt")
            else:
                row[f"fd:{encoder}"] = row[f"fd_residue:{encoder}"] = np.nan
                reasons.append(f"FD needs more than {d} images per side (the feature dimension): "
                               f"{min(len(fr), len(fg))}")
        if "kid" in options.metrics:
            if min(len(fr), len(fg)) >= 2:
                k = kid(fr, fg, subsets=options.kid_subsets, subset_size=options.kid_subset_size,
                        seed=options.seed)
                row[f"kid:{encoder}"], row[f"kid_std:{encoder}"] = k["kid"], k["kid_std"]
                row["kid_subset_size"] = k["kid_subset_size"]
                if k.get("reason"):
                    reasons.append(k["reason"])
            else:  # e.g. the frames of a one-frame scene: undefined, with the reason
                row[f"kid:{encoder}"] = row[f"kid_std:{encoder}"] = np.nan
                row["kid_subset_size"] = pd.NA
                reasons.append(f"KID needs at least 2 images per side: {len(fr)} render, {len(fg)} gt")
        row["reason"] = "; ".join(reasons)
        rows.append(row)
    out = pd.DataFrame(rows)
    if "kid_subset_size" in out:
        out["kid_subset_size"] = out["kid_subset_size"].astype("Int64")
    return out[[c for c in out.columns if c != "reason"] + ["reason"]]


def score_sets(scene, options: SetOptions, *, encoder=None, batch_size: int = 32, progress: bool = False,
               known: dict | None = None, pairs: pd.DataFrame | None = None):
    """Embed every image of every set of ``scene`` once and score the sets.

    Parameters
    ----------
    scene : data_schema.scene.Scene
    options : SetOptions
    encoder : str, EncoderConfig or Encoder, optional
        As :func:`embed` (default ``efficientnet-lite0``).
    batch_size : int, optional
        Images per forward pass.
    progress : bool, optional
        A progress bar over the distinct images.
    known : dict, optional
        Crop embeddings already made by this encoder (:func:`crop_features`): a crop found in
        it is not read nor embedded again.
    pairs : pandas.DataFrame, optional
        The scene's pairs table, as :func:`set_groups` (default: made here).

    Returns
    -------
    table : pandas.DataFrame
        :func:`set_table`.
    groups : pandas.DataFrame
        :func:`set_groups` (the rows of ``features``).
    features : numpy.ndarray
        (n, d) one row per row of ``groups`` (a distinct image or crop is embedded once).
    name : str
        The encoder's name.
    """
    from tqdm.auto import tqdm

    groups = set_groups(scene, options, pairs=pairs)
    enc = _loaded(encoder)
    _check_sizes(groups, options, enc, where=str(scene.root))
    keys = groups["path"].astype(str) + "|" + groups["box"].map(lambda b: "" if b is None else str(b))
    codes = pd.factorize(keys)[0]  # codes in order of first appearance
    first = np.flatnonzero(~pd.Series(codes).duplicated().to_numpy())
    paths = groups["path"].astype(str).to_numpy()[first]
    whole = groups["box"].isna().to_numpy()[first]
    # one pass over the distinct images in path order: each file is decoded once, for its whole
    # frame and all its crops; the encoder inputs wait in one batch per input mode
    order = np.argsort(paths, kind="stable")
    uniq = None
    bar = tqdm(total=len(first), desc="sets: embed", unit="image", disable=not progress)
    reader = _Reader(scene.root)
    pending = {"stretch": [], "pad": []}
    if known:
        boxes = groups["box"].to_numpy()[first]
        found = {k: known.get(_crop_key(scene.root / paths[k], boxes[k])) for k in np.flatnonzero(~whole)}
        found = {k: f for k, f in found.items() if f is not None}
        if found:
            uniq = np.empty((len(first), len(next(iter(found.values())))))
            uniq[list(found)] = np.stack(list(found.values()))
            order = order[~np.isin(order, list(found))]
            bar.update(len(found))

    def flush(mode):
        nonlocal uniq
        ks = pending[mode]
        f = embed([im for _, im in ks], encoder=enc, batch_size=batch_size, square=mode)
        uniq = np.empty((len(first), f.shape[1])) if uniq is None else uniq
        uniq[[k for k, _ in ks]] = f
        bar.update(len(ks))
        pending[mode] = []

    for k in order:
        mode = "stretch" if whole[k] else "pad"
        pending[mode].append((k, reader(paths[k], groups["box"].iat[first[k]])))
        if len(pending[mode]) == batch_size:
            flush(mode)
    for mode in pending:
        if pending[mode]:
            flush(mode)
    bar.close()
    features = uniq[codes]
    name = enc.spec.name
    table = set_table(groups, features, options, encoder=name, where=str(scene.root), progress=progress)
    table.insert(1, "clip_id", scene.clip_id)  # the scene, which analyze --sets checks
    return table, groups, features, name


def encoder_identity(encoder) -> dict:
    """What makes a loaded encoder's embeddings the ones another run made: its name, runtime,
    precision, device and the hash of its weights.

    Parameters
    ----------
    encoder : Encoder
        A loaded encoder (:func:`nvrq.encoders.load_encoder`).

    Returns
    -------
    dict
        ``encoder``, ``runtime``, ``precision``, ``device``, ``weights_hash`` (str each).
    """
    from nvrq.encoders.runtimes import weights_hash

    whash = getattr(encoder, "weights_hash", None)
    if whash is None and hasattr(encoder, "model"):
        whash = weights_hash(encoder.model)
    return {"encoder": encoder.spec.name, "runtime": str(encoder.runtime), "precision": str(encoder.precision),
            "device": str(encoder.device), "weights_hash": str(whash or "")}


def save_crop_features(path, pairs, features, encoder) -> None:
    """Write the crop embeddings of ``nvrq score`` (``--save-crop-features``), for
    :func:`crop_features`.

    Parameters
    ----------
    path : str or Path
        The ``.npz`` file.
    pairs : data_schema.tables.PairsTable
        The scored pairs (absolute image paths, integer boxes).
    features : tuple of two (N, D) arrays
        The GT and render crops' embeddings, row k for pair k (:attr:`ScoreResult.features`).
    encoder : Encoder
        The encoder that made them (:func:`encoder_identity`).
    """
    import json

    f_gt, f_render = features
    paths = np.concatenate([pairs.gt_paths, pairs.render_paths]).astype(str)
    with open(path, "wb") as f:
        np.savez(f, features=np.concatenate([f_gt, f_render]), path=paths,
                 box=np.concatenate([pairs.gt_boxes, pairs.render_boxes]).astype(np.int64),
                 identity=np.array(json.dumps(encoder_identity(encoder), sort_keys=True)))


def crop_features(path, encoder) -> dict:
    """The crop embeddings of a :func:`save_crop_features` file, for :func:`score_sets`.

    Parameters
    ----------
    path : str or Path
        The ``.npz`` file ``nvrq score --save-crop-features`` wrote.
    encoder : str, EncoderConfig or Encoder
        The encoder of the sets (as :func:`embed`): the file's must be the same
        (:func:`encoder_identity`).

    Returns
    -------
    dict
        ``{(real path, x0, y0, x1, y1): (D,) float64}``.

    Raises
    ------
    InputError
        Naming ``path``: not such a file, or made by another encoder, runtime, precision,
        device or weights.
    """
    import json
    import zipfile

    try:
        with np.load(path, allow_pickle=False) as z:
            feats, paths, boxes = z["features"], z["path"], z["box"]
            made = json.loads(str(z["identity"]))
    except (OSError, KeyError, ValueError, zipfile.BadZipFile) as e:
        raise InputError(path, None, "a crop features file written by nvrq score (its save_crop_features output)",
                         f"{type(e).__name__}: {e}") from None
    ours = encoder_identity(_loaded(encoder))
    if made != ours:
        diff = ", ".join(f"{k} {made.get(k)}" for k in ours if made.get(k) != ours[k])
        raise InputError(path, "identity", "crop features of the encoder of the sets (" +
                         ", ".join(f"{k} {ours[k]}" for k in ours if made.get(k) != ours[k]) + ")", diff)
    return {_crop_key(p, b): f for p, b, f in zip(paths, boxes.tolist(), feats.astype(np.float64), strict=True)}


def _crop_key(path, box) -> tuple:
    """One crop: the file's real path and the box's four integers."""
    import os

    return (os.path.realpath(path), *(int(v) for v in box))


def _check_sizes(groups: pd.DataFrame, options: SetOptions, enc, *, where: str) -> None:
    """Before any image is read: with FD alone, every set has more images per side than the
    feature dimension (the dimension from one blank input). With KID a smaller set is kept and
    gets no value, with its reason (:func:`set_table`)."""
    n = groups.groupby(["set_id", "side"]).size().unstack(fill_value=0).reindex(columns=["render", "gt"],
                                                                                 fill_value=0)
    low = n.min(axis=1)
    if options.metrics == ("fd",):
        s = enc.spec.input_size
        d = int(np.asarray(enc.embed(np.zeros((1, s, s, 3), np.uint8))).shape[1])
        if (low <= d).any():
            sid = low.index[int(np.argmax((low <= d).to_numpy()))]
            raise InputError(where, f"set {sid}", f"more than {d} images per side for FD (the feature dimension "
                             f"of {enc.spec.name}; add kid to get KID alone)",
                             f"{n.loc[sid, 'render']} render, {n.loc[sid, 'gt']} gt")


class _Reader:
    """Images of a scene, the last one kept (the crops of one render come one after another)."""

    def __init__(self, root):
        self.root, self.path, self.image = root, None, None

    def __call__(self, path: str, box):
        from nvrq.crops import cut_box, read_rgb

        if path != self.path:
            self.path, self.image = path, read_rgb(self.root / path)
        return self.image if box is None else cut_box(self.image, box, where=str(path))


def _loaded(encoder):
    """``encoder`` itself when it is loaded, else the encoder an ``EncoderConfig`` or a name
    (None: the default) means, from the API's cache of loaded encoders."""
    if hasattr(encoder, "embed"):
        return encoder
    from nvrq.api import _cached_encoder
    from nvrq.encoders import EncoderConfig

    return _cached_encoder(encoder if isinstance(encoder, EncoderConfig) else EncoderConfig(name=encoder))
