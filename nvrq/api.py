"""NVRQ from Python: score crops and frames held in memory, inside any evaluation loop.

The functions here are a thin door onto the same core as ``nvrq score``
(:func:`nvrq.scoring.core.score_crop_batch`: the same crop cutter, resize, encoder inputs and
metric functions; the columns resolved by :mod:`nvrq.metrics.resolve`), so the numbers equal
the command's on the same pairs. The functions and :class:`Evaluator` share pure helpers, as
torchmetrics' functional and class metrics do: :func:`score_crops` keeps no state of its own
but the encoders it loaded (a small cache keyed by :class:`~nvrq.encoders.EncoderConfig`,
emptied by :func:`clear_encoder_cache`), the class adds only what it holds (its loaded
encoder, the pending and scored pairs). Neither imports the table driver
(:mod:`nvrq.scoring.driver`):

- :func:`score_crops`: GT and render crops -> one row per pair, one column per metric, named
  as ``nvrq score`` names them (``psnr``, ``nvrq:ENCODER``, ``nvrq_ca:ENCODER``, ...).
- :func:`score_frame`: a GT image, a render image and their (N, 4) boxes; the GT image is cut
  once and equal GT boxes share one crop (embedded once).
- :func:`clear_encoder_cache`: forget the encoders the two functions loaded (their memory is
  freed once nothing else holds them).
- :class:`Evaluator`: loads the encoder (and its exported runtime) once, scores with
  :meth:`~Evaluator.score_crops` / :meth:`~Evaluator.score_frame`, and accumulates
  torchmetrics-style: :meth:`~Evaluator.update` with optional per-pair labels (view, class,
  any key), :meth:`~Evaluator.compute` (the summary per label group), :meth:`~Evaluator.reset`.

Convention:
    A crop or image is a numpy ``uint8`` array (H, W, 3), channels R, G, B, or a torch tensor
    (3, H, W) of ``uint8`` or of floats in [0, 1] (on any device; a float value ``x`` is the
    level ``round(255 x)``, so ``u / 255`` gives back ``u`` exactly). Sizes may differ from
    pair to pair. A box is ``[x0, y0, x1, y1]`` in inclusive pixel indices, as in the pairs
    table (docs/FORMATS.md §3): the crop is ``image[y0:y1 + 1, x0:x1 + 1]``.

Bad input raises :class:`data_schema.errors.InputError` (a ``ValueError``) naming the argument
(``render_crops[3]``, ``gt_boxes``, ``metrics``) and what was expected.

>>> import numpy as np
>>> gt = np.zeros((4, 6, 3), np.uint8)
>>> score_crops([gt, gt], [gt, np.full((2, 3, 3), 9, np.uint8)], metrics=["mse", "psnr"]).round(3)
    mse    psnr
0   0.0     inf
1  81.0  29.046
"""

from __future__ import annotations

import sys
import threading
from collections import OrderedDict
from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from data_schema.errors import InputError, check_int
from nvrq.crops import cut_box
from nvrq.encoders.registry import Encoder, EncoderConfig
from nvrq.scoring.core import CropBatch, compute_columns
from nvrq.scoring.plan import ScorePlan, resolve_plan

__all__ = ["score_crops", "score_frame", "Evaluator", "as_rgb_uint8", "clear_encoder_cache",
           "ENCODER_CACHE_SIZE"]

_CROP = "a numpy uint8 (H, W, 3) RGB array, or a torch tensor (3, H, W) of uint8 or of floats in [0, 1]"


def _describe(x) -> str:
    shape = tuple(getattr(x, "shape", ()))
    dtype = getattr(x, "dtype", None)
    return f"{type(x).__module__.split('.')[0]} {dtype} {shape}" if dtype is not None else type(x).__name__


def _torch_tensor(x) -> bool:
    torch = sys.modules.get("torch")  # a tensor exists only if torch is imported
    return torch is not None and isinstance(x, torch.Tensor)


def _hwc(x, name: str):
    """``x`` checked and seen as (H, W, 3): the numpy array itself, or a torch tensor's
    (H, W, 3) view (not copied, still on its device)."""
    if isinstance(x, np.ndarray):
        if x.dtype != np.uint8 or x.ndim != 3 or x.shape[2] != 3 or 0 in x.shape:
            raise InputError(param=name, expected=_CROP, got=_describe(x))
        return x
    if _torch_tensor(x):
        import torch

        ok_dtype = x.dtype == torch.uint8 or x.is_floating_point()
        if not ok_dtype or x.ndim != 3 or x.shape[0] != 3 or 0 in x.shape:
            raise InputError(param=name, expected=_CROP, got=_describe(x))
        if x.is_floating_point():
            lo, hi = torch.aminmax(x.detach())
            lo, hi = float(lo), float(hi)
            if not (0.0 <= lo and hi <= 1.0):  # NaN fails both
                raise InputError(param=name, expected="float values in [0, 1]", got=f"values in [{lo:.4g}, {hi:.4g}]")
        return x.permute(1, 2, 0)
    raise InputError(param=name, expected=_CROP, got=_describe(x))


def _to_uint8(hwc) -> np.ndarray:
    """A checked (H, W, 3) numpy array or torch view -> numpy uint8 (H, W, 3) on the host."""
    if isinstance(hwc, np.ndarray):
        return hwc
    import torch

    with torch.no_grad():
        if hwc.is_floating_point():
            hwc = hwc.mul(255.0).round_().to(torch.uint8)
        return np.ascontiguousarray(hwc.cpu().numpy())


def as_rgb_uint8(x, *, name: str = "image") -> np.ndarray:
    """One crop or image as a numpy ``uint8`` (H, W, 3) RGB array (the module's convention).

    ``x``: numpy uint8 (H, W, 3) (returned as is), or a torch tensor (3, H, W), uint8 or float
    in [0, 1] (``round(255 x)``, copied to the host). :class:`InputError` naming ``name``
    otherwise.

    Parameters
    ----------
    x : numpy.ndarray or torch.Tensor
        numpy uint8 (H, W, 3) RGB, or a torch tensor (3, H, W) of uint8 or floats in [0, 1].
    name : str, optional
        Name of the argument that error messages cite (default ``"image"``).

    Returns
    -------
    numpy.ndarray
        (H, W, 3) uint8 RGB array on the host.

    >>> as_rgb_uint8(np.zeros((2, 3, 3), np.uint8)).shape
    (2, 3, 3)
    >>> as_rgb_uint8(np.zeros((2, 3), np.uint8), name="crop")
    Traceback (most recent call last):
    ...
    data_schema.errors.InputError: crop: expected a numpy uint8 (H, W, 3) RGB array, or a torch tensor (3, H, W) of uint8 or of floats in [0, 1], got numpy uint8 (2, 3)
    """
    return _to_uint8(_hwc(x, name))


def _as_list(items, name: str) -> list:
    """A sequence of crops: a list/tuple, or a batch array/tensor split along its first axis."""
    if isinstance(items, (list, tuple)):
        return list(items)
    if isinstance(items, np.ndarray) or _torch_tensor(items):
        if items.ndim != 4:
            raise InputError(param=name, expected="a list of crops, or a batch (N, H, W, 3) numpy / (N, 3, H, W) torch", got=_describe(items))
        return list(items)
    raise InputError(param=name, expected="a list of crops (" + _CROP + ")", got=_describe(items))


def _boxes(boxes, name: str) -> np.ndarray:
    """(N, 4) int64 inclusive boxes; :class:`InputError` naming ``name`` otherwise."""
    if _torch_tensor(boxes):
        boxes = boxes.detach().cpu().numpy()
    arr = np.asarray(boxes)
    if arr.ndim != 2 or arr.shape[1] != 4 or not (np.issubdtype(arr.dtype, np.integer)
                                                 or (np.issubdtype(arr.dtype, np.floating)
                                                     and np.all(arr == np.round(arr)))):
        raise InputError(param=name, expected="an (N, 4) array of integer inclusive pixel boxes x0, y0, x1, y1", got=f"{arr.dtype} {arr.shape}")
    return arr.astype(np.int64)


def _share(keys: Sequence, make, *, seen: dict | None = None, out: list | None = None) -> tuple:
    """``(out, index, seen)``: ``out`` gains ``make(k)`` for each ``keys[k]`` not yet in ``seen``
    (key -> its position in ``out``); ``index`` (len(keys),) int64 is each key's position. The GT
    crops of one call, and of the pending calls of :meth:`Evaluator._flush`, are shared this way.

    >>> keys = ["a", "b", "a"]
    >>> _share(keys, lambda k: keys[k].upper())[:2]
    (['A', 'B'], array([0, 1, 0]))
    """
    seen = {} if seen is None else seen
    out = [] if out is None else out
    index = np.empty(len(keys), np.int64)
    for k, key in enumerate(keys):
        j = seen.get(key)
        if j is None:
            j = seen[key] = len(out)
            out.append(make(k))
        index[k] = j
    return out, index, seen


# --- the pure helpers behind score_crops / score_frame and Evaluator (torchmetrics' pattern) ---

#: the options score_crops, score_frame and Evaluator take besides ``metrics`` and ``encoder``
_OPTIONS = {"weights": None, "device": "cpu", "runtime": "auto", "tau": None, "batch_size": 32}


def _plan(metrics, encoder, options: dict) -> ScorePlan:
    """The run's :class:`~nvrq.scoring.plan.ScorePlan` (:func:`~nvrq.scoring.plan.resolve_plan`:
    the columns, the encoder's config, tau by :func:`nvrq.metrics.tau_config.require_tau`), every option
    checked once, here; ``metrics`` may be a plan already made (then no other option)."""
    unknown = sorted(set(options) - set(_OPTIONS))
    if unknown:
        raise TypeError(f"unexpected keyword argument {unknown[0]!r} (options: {', '.join(_OPTIONS)})")
    if isinstance(metrics, ScorePlan):
        if options or encoder is not None and not isinstance(encoder, Encoder):
            raise InputError(param="metrics", expected="a ScorePlan alone (its encoder, tau and batch size "
                             "are its own; a loaded encoder may be given)", got=", ".join(options) or "encoder")
        return metrics
    opts = {**_OPTIONS, **options}
    weights, device, runtime = opts["weights"], opts["device"], opts["runtime"]
    if encoder is not None and not isinstance(encoder, str):
        # a config or a loaded encoder carries its own loading options: none is dropped silently
        for option, value, default in (("weights", weights, None), ("device", device, "cpu"),
                                       ("runtime", runtime, "auto")):
            if value != default:
                raise InputError(param=option, expected=f"no {option} beside an EncoderConfig or a loaded "
                                 "encoder (give it in the config)", got=value)
    given = encoder.spec.name if isinstance(encoder, Encoder) else encoder
    options = {"weights": weights, "device": device, "runtime": runtime} if not isinstance(encoder, EncoderConfig) else None
    return resolve_plan(metrics, encoder=given, encoder_options=options, tau=opts["tau"], batch_size=opts["batch_size"])


def _load(encoder, plan: ScorePlan, *, cached: bool) -> Encoder | None:
    """The loaded encoder of ``plan`` (``None`` without encoder columns): ``encoder`` itself
    when it is loaded, else the plan's config, loaded (from the cache with ``cached``)."""
    if not plan.encoder_specs:
        return None
    if isinstance(encoder, Encoder):
        return encoder
    if cached:
        return _cached_encoder(plan.encoder)
    from nvrq.encoders import load_encoder

    return load_encoder(plan.encoder)


# --- the encoders score_crops / score_frame loaded, kept for their next call -----------------

#: How many loaded encoders :func:`score_crops` / :func:`score_frame` keep (the least recently
#: used one is dropped first).
ENCODER_CACHE_SIZE = 2
_ENCODERS: OrderedDict[EncoderConfig, Encoder] = OrderedDict()
_ENCODERS_LOCK = threading.Lock()


def _cached_encoder(config: EncoderConfig) -> Encoder:
    """The encoder of ``config``, loaded on the first call (:func:`nvrq.encoders.load_encoder`)
    and kept in a least-recently-used cache of :data:`ENCODER_CACHE_SIZE` entries keyed by the
    frozen config (name, weights path, device, runtime, precision, threads, cache folder)."""
    with _ENCODERS_LOCK:
        found = _ENCODERS.get(config)
        if found is not None:
            _ENCODERS.move_to_end(config)
            return found
    from nvrq.encoders import load_encoder

    loaded = load_encoder(config)  # outside the lock: a load takes seconds
    with _ENCODERS_LOCK:
        loaded = _ENCODERS.setdefault(config, loaded)  # a concurrent load of it wins once
        _ENCODERS.move_to_end(config)
        while len(_ENCODERS) > ENCODER_CACHE_SIZE:
            _ENCODERS.popitem(last=False)
    return loaded


def clear_encoder_cache() -> int:
    """Forget the encoders :func:`score_crops` and :func:`score_frame` keep between calls.

    The two functions load an encoder on their first call with a given
    :class:`~nvrq.encoders.EncoderConfig` (encoder name, ``weights``, ``device``, ``runtime``, ...)
    and reuse it afterwards (up to :data:`ENCODER_CACHE_SIZE` of them, least recently used
    dropped first). Clear the cache to free their memory (a GPU encoder's too, once nothing else
    holds it), or after the weights file behind a config changed on disk. An
    :class:`Evaluator` holds its own encoder and is not affected.

    Returns
    -------
    int
        How many encoders were dropped.

    >>> dropped = clear_encoder_cache()  # whatever earlier calls loaded
    >>> clear_encoder_cache()  # nothing is left to drop
    0
    """
    with _ENCODERS_LOCK:
        n = len(_ENCODERS)
        _ENCODERS.clear()
    return n


def _check_no_reference(plan: ScorePlan, name: str) -> None:
    """No GT (``name`` is None): only no-reference metrics can run."""
    needs_gt = plan.reference_columns
    if needs_gt:
        raise InputError(param=name, expected=f"the GT for the reference metrics {', '.join(needs_gt)} "
                         "(only no-reference metrics score renders alone)", got=None)


def _crop_inputs(plan: ScorePlan, gt_crops, render_crops) -> tuple:
    """Checked host crops ``(gt_u8, gt_index, r_u8, gt_keys, owner)`` of a crop list (GT
    objects once; ``gt_keys``: each GT crop's identity, valid while ``owner`` is held)."""
    renders = _as_list(render_crops, "render_crops")
    if gt_crops is None:  # no-reference metrics only
        _check_no_reference(plan, "gt_crops")
        return [], None, [as_rgb_uint8(r, name=f"render_crops[{k}]") for k, r in enumerate(renders)], [], None
    gts = _as_list(gt_crops, "gt_crops")
    if len(gts) != len(renders):
        raise InputError(param="render_crops", expected=f"one render crop per GT crop ({len(gts)})", got=f"{len(renders)} crops")
    # one crop per GT object (by id; the list keeps the objects alive)
    gt_u8, index, seen = _share([id(g) for g in gts], lambda k: as_rgb_uint8(gts[k], name=f"gt_crops[{k}]"))
    r_u8 = [as_rgb_uint8(r, name=f"render_crops[{k}]") for k, r in enumerate(renders)]
    return gt_u8, index, r_u8, [("crop", i) for i in seen], gts


def _frame_inputs(plan: ScorePlan, gt_image, render_image, gt_boxes, render_boxes) -> tuple:
    """Checked host crops ``(gt_u8, gt_index, r_u8, gt_keys, owner)`` of a frame pair (one
    crop per GT box; ``gt_keys``: GT image identity and box, valid while ``owner`` is held)."""
    r_hwc, rb = _hwc(render_image, "render_image"), _boxes(render_boxes, "render_boxes")
    if gt_image is None:  # no-reference metrics only
        _check_no_reference(plan, "gt_image")
        return [], None, [_to_uint8(cut_box(r_hwc, b, where=f"render_boxes[{k}]")) for k, b in enumerate(rb)], [], None
    gt_hwc, gb = _hwc(gt_image, "gt_image"), _boxes(gt_boxes, "gt_boxes")
    if len(gb) != len(rb):
        raise InputError(param="render_boxes", expected=f"one render box per GT box ({len(gb)})", got=f"{len(rb)} boxes")
    # one crop per distinct GT box, as nvrq.scoring.batches does per GT image
    gt_u8, index, seen = _share([tuple(b) for b in gb.tolist()],
                                lambda k: _to_uint8(cut_box(gt_hwc, gb[k], where=f"gt_boxes[{k}]")))
    r_u8 = [_to_uint8(cut_box(r_hwc, b, where=f"render_boxes[{k}]")) for k, b in enumerate(rb)]
    return gt_u8, index, r_u8, [("frame", id(gt_image), *key) for key in seen], gt_image


def _box_table(gt_boxes, render_boxes):
    """``(gt_boxes, render_boxes, visibility)``: a :func:`nvrq.project_boxes` table given as
    ``gt_boxes`` (its kept rows; ``render_boxes`` None) gives both boxes and its visibility
    columns (a DataFrame, else None)."""
    if not isinstance(gt_boxes, pd.DataFrame) or render_boxes is not None:
        return gt_boxes, render_boxes, None
    from nvrq.pairs import VISIBILITY_COLUMNS

    need = [f"{s}_{c}" for s in ("gt", "r") for c in ("x0", "y0", "x1", "y1")]
    missing = [c for c in need if c not in gt_boxes.columns]
    if missing:
        raise InputError(param="gt_boxes", field=missing[0],
                         expected="a project_boxes() table (with render_boxes=None) or (N, 4) boxes",
                         got=f"a table without {missing[0]}")
    table = gt_boxes[gt_boxes["kept"]] if "kept" in gt_boxes.columns else gt_boxes
    vis = table.loc[:, [c for c in VISIBILITY_COLUMNS if c in table.columns]].reset_index(drop=True)
    return (table[need[:4]].to_numpy(np.int64), table[need[4:]].to_numpy(np.int64),
            vis if len(vis.columns) else None)


def _score(plan: ScorePlan, encoder, gt_u8: list, gt_index: np.ndarray | None, r_u8: list) -> pd.DataFrame:
    """The core on one batch (:func:`nvrq.scoring.core.compute_columns`, the plan checked once):
    ``gt_index`` None (and no GT crops) for no-reference metrics."""
    index = None if gt_index is None else np.asarray(gt_index, np.int64)
    batch = CropBatch(np.arange(len(r_u8), dtype=np.int64), gt_u8, index, r_u8)
    cols = compute_columns(batch, plan.specs, encoder=encoder, tau=plan.tau, batch_size=plan.batch_size)
    return pd.DataFrame(cols, columns=list(plan.columns))


def _summary(table: pd.DataFrame, columns: Sequence[str], keys: Sequence[str]) -> pd.DataFrame:
    """One row per group of ``table`` by ``keys`` (none: one row), with ``pairs`` and each
    metric column's mean (NaN values skipped)."""
    columns = list(columns)
    values = table[columns].astype(np.float64)
    if not keys:
        return pd.DataFrame([{"pairs": len(table), **values.mean().to_dict()}], columns=["pairs", *columns])
    grouped = values.groupby([table[k] for k in keys], sort=True, dropna=False)
    out = grouped.mean()
    out.insert(0, "pairs", grouped.size())
    return out.reset_index()


class Evaluator:
    """Scores pairs of crops with one loaded encoder, and accumulates them for a summary.

    Parameters
    ----------
    metrics : sequence of str, a comma-separated str, or ScorePlan
        Metric names (``psnr``, ``ssim``, ``ms_ssim``, ``gmsd``, ``mse``, ``mae``, ``nvrq``,
        ``nvrq_ca``, ...) or columns (``nvrq:dinov2-small``); see :mod:`nvrq.metrics.registry`.
        Or a plan made by :func:`nvrq.scoring.plan.resolve_plan` (then no other option but a
        loaded ``encoder``).
    encoder : str, EncoderConfig or Encoder, optional
        For ``nvrq``/``nvrq_ca``: a registry name (default ``efficientnet-lite0``), an
        :class:`~nvrq.encoders.EncoderConfig`, or an encoder already loaded
        (:func:`nvrq.encoders.load_encoder`). Loaded once, here.
    update_pairs : int
        :meth:`update` scores once this many pairs are pending (default 256, the pairs per crop
        batch of ``nvrq score``), so small updates still fill the encoder's batches.
    **options
        ``weights``, ``device`` (default ``cpu``), ``runtime`` (default ``auto``): with an
        encoder name, the :class:`~nvrq.encoders.EncoderConfig` fields (``runtime='auto'``: on
        CPU the fastest exported runtime identical to torch fp32; torch on ``cuda``).
        ``tau``: the NVRQ-CA knee; default as ``nvrq score``: the user config, then the
        registry (:func:`nvrq.metrics.tau_config.require_tau`). ``batch_size``: crops per encoder pass
        (default 32). All go to :func:`nvrq.scoring.plan.resolve_plan`, checked once.

    Raises
    ------
    InputError
        Naming the argument (``metrics``, ``tau``, ``batch_size``, ...) before the encoder loads.

    Convention: see the module docstring. ``compute()`` summarises the pairs given to
    ``update()`` since the last ``reset()``.

    >>> ev = Evaluator(metrics=["mae"])
    >>> gt = np.zeros((4, 4, 3), np.uint8)
    >>> ev.update([gt, gt], [gt, gt + 10], labels={"view": ["+1m", "+2m"]})
    >>> ev.update([gt], [gt + 30], labels={"view": ["+2m"]})
    >>> ev.compute()
      view  pairs   mae
    0  +1m      1   0.0
    1  +2m      2  20.0
    """

    def __init__(self, *, metrics, encoder: str | EncoderConfig | Encoder | None = None,
                 update_pairs: int = 256, **options):
        self.update_pairs = check_int("update_pairs", update_pairs)
        self._plan = _plan(metrics, encoder, options)
        self._encoder = _load(encoder, self._plan, cached=False)
        self.reset()

    @property
    def plan(self) -> ScorePlan:
        """The scoring plan, resolved once (:func:`nvrq.scoring.plan.resolve_plan`)."""
        return self._plan

    @property
    def columns(self) -> list[str]:
        """The metric columns, as ``nvrq score`` names them."""
        return list(self._plan.columns)

    @property
    def encoder(self) -> Encoder | None:
        """The loaded encoder (``None`` without encoder metrics)."""
        return self._encoder

    @property
    def tau(self) -> float | None:
        """NVRQ-CA's knee (``None`` without NVRQ-CA)."""
        return self._plan.tau

    @property
    def batch_size(self) -> int:
        """Crops per encoder pass."""
        return self._plan.batch_size

    # --- scoring ---------------------------------------------------------------------------

    def score_crops(self, gt_crops, render_crops) -> pd.DataFrame:
        """One row per pair, one column per metric (see :func:`score_crops`)."""
        return _score(self._plan, self._encoder, *_crop_inputs(self._plan, gt_crops, render_crops)[:3])

    def score_frame(self, gt_image, render_image, gt_boxes, render_boxes) -> pd.DataFrame:
        """One row per box pair (see :func:`score_frame`)."""
        gt_boxes, render_boxes, vis = _box_table(gt_boxes, render_boxes)
        out = _score(self._plan, self._encoder, *_frame_inputs(self._plan, gt_image, render_image, gt_boxes,
                                                               render_boxes)[:3])
        return out if vis is None else pd.concat([vis, out], axis=1)

    # --- accumulation ----------------------------------------------------------------------

    def reset(self) -> None:
        """Forget the pairs given to :meth:`update` (scored or still pending)."""
        self._parts: list[pd.DataFrame] = []
        self._pending: list[tuple] = []  # (labels, gt_u8, gt_index, r_u8, gt_keys, owner)
        self._label_keys: list[str] = []

    def update(self, gt_crops, render_crops, *, labels: Mapping | pd.DataFrame | None = None) -> None:
        """Add pairs of crops (as :meth:`score_crops` takes them) for :meth:`compute`.

        ``labels``: per-pair keys, ``{key: one value for all pairs, or (N,) values}`` or a
        DataFrame of N rows (e.g. ``view``, ``class``, ``track_id``). The crops are checked and
        brought to the host now; they are scored in batches of at least ``update_pairs`` pairs
        (full encoder batches, as ``nvrq score`` runs them) and by :meth:`compute` /
        :attr:`pairs`.
        """
        self._add(_crop_inputs(self._plan, gt_crops, render_crops), labels)

    def update_frame(self, gt_image, render_image, gt_boxes, render_boxes, *,
                     labels: Mapping | pd.DataFrame | None = None) -> None:
        """Add a frame's box pairs (as :meth:`score_frame` takes them) for :meth:`compute`; a
        :func:`project_boxes` table adds its visibility columns to the labels."""
        gt_boxes, render_boxes, vis = _box_table(gt_boxes, render_boxes)
        if vis is not None:
            given = _labels(labels, len(vis))
            labels = pd.concat([given.reset_index(drop=True), vis.drop(columns=list(given.columns), errors="ignore")],
                               axis=1)
        self._add(_frame_inputs(self._plan, gt_image, render_image, gt_boxes, render_boxes), labels)

    def _add(self, crops: tuple, labels) -> None:
        lab = _labels(labels, len(crops[2]))
        clash = [k for k in lab.columns if k in self.columns or k == "pairs"]
        if clash:
            raise InputError(param="labels", field=clash[0], expected="label keys other than the metric columns and 'pairs'", got=clash[0])
        if self._pending and (crops[1] is None) != (self._pending[0][2] is None):
            self._flush()  # a no-reference batch is not mixed with one that has GT crops
        self._label_keys.extend(k for k in lab.columns if k not in self._label_keys)
        self._pending.append((lab, *crops))
        if sum(len(p[3]) for p in self._pending) >= self.update_pairs:
            self._flush()

    def _flush(self) -> None:
        """Score the pending pairs in one core call; a GT crop given again (the same GT object,
        or the same box of the same GT image object) is embedded once, as in one call."""
        if not self._pending:
            return
        gt_u8, index, r_u8, position = [], [], [], {}
        for _, g, i, r, keys, _owner in self._pending:
            if i is not None:
                local = _share(keys, g.__getitem__, seen=position, out=gt_u8)[1]
                index.append(local[np.asarray(i, np.int64)])
            r_u8.extend(r)
        scores = _score(self._plan, self._encoder, gt_u8, np.concatenate(index) if index else None, r_u8)
        labels = pd.concat([p[0] for p in self._pending], ignore_index=True)
        self._parts.append(pd.concat([labels, scores], axis=1))
        self._pending = []

    @property
    def pairs(self) -> pd.DataFrame:
        """Every pair given to :meth:`update` since :meth:`reset`: labels, then metric columns."""
        self._flush()
        if not self._parts:
            return pd.DataFrame(columns=[*self._label_keys, *self.columns])
        return pd.concat(self._parts, ignore_index=True).loc[:, [*self._label_keys, *self.columns]]

    def compute(self, by: Sequence[str] | None = None) -> pd.DataFrame:
        """The summary: one row per label group (``by``, default every label key given to
        :meth:`update`, in first-seen order, but the visibility columns; none: one row of all pairs), with ``pairs`` (the
        group's pair count) and each metric's mean over the group (NaN values skipped). A
        metric NaN on every pair (e.g. crops below its ``min_side``) gets a ``UserWarning``."""
        import warnings

        from nvrq.scoring.core import empty_column_warning

        table = self.pairs
        from nvrq.pairs import VISIBILITY_COLUMNS

        keys = list([k for k in self._label_keys if k not in VISIBILITY_COLUMNS] if by is None else by)
        missing = [k for k in keys if k not in self._label_keys]
        if missing:
            raise InputError(param="by", expected=f"label keys among {', '.join(self._label_keys) or 'none'}", got=missing[0])
        for c in self.columns:
            if len(table) and not np.isfinite(table[c].to_numpy(np.float64)).any():
                warnings.warn(empty_column_warning(c, len(table)).removeprefix("warning: "), stacklevel=2)
        return _summary(table, self.columns, keys)


def _labels(labels, n: int) -> pd.DataFrame:
    """Per-pair labels as an (n, K) DataFrame."""
    if labels is None:
        return pd.DataFrame(index=range(n))
    if isinstance(labels, pd.DataFrame):
        if len(labels) != n:
            raise InputError(param="labels", expected=f"{n} rows, one per pair", got=f"{len(labels)} rows")
        return labels.reset_index(drop=True)
    if not isinstance(labels, Mapping):
        raise InputError(param="labels", expected="a mapping {key: value or (N,) values} or a DataFrame", got=type(labels).__name__)
    cols = {}
    for key, value in labels.items():
        if np.ndim(value) == 0:
            cols[str(key)] = [value] * n
        elif len(value) != n:
            raise InputError(param="labels", field=str(key), expected=f"one value, or {n} values (one per pair)", got=f"{len(value)} values")
        else:
            cols[str(key)] = list(value)
    return pd.DataFrame(cols, index=range(n))


def score_crops(gt_crops, render_crops, *, metrics, encoder=None, **options) -> pd.DataFrame:
    """Metrics of pairs of crops held in memory: one row per pair, one column per metric.

    Parameters
    ----------
    gt_crops, render_crops : sequence of N crops
        Each a numpy uint8 (H, W, 3) RGB array or a torch tensor (3, H, W) (uint8, or float in
        [0, 1]); a batch array (N, H, W, 3) / tensor (N, 3, H, W) also works. Sizes may differ
        from pair to pair. The same GT array object repeated in ``gt_crops`` is embedded once.
        ``gt_crops=None`` when every metric is a no-reference one (``niqe``, ``brisque``, ...:
        the render crop alone).
    metrics, encoder, **options
        As :class:`Evaluator` (``weights``, ``device``, ``runtime``, ``tau``, ``batch_size``). An encoder given by name or config is loaded on the first call
        and kept for the next ones with the same config (:func:`clear_encoder_cache` frees it);
        an :class:`Evaluator` also keeps the pending pairs and sums them up.

    Returns
    -------
    pandas.DataFrame
        N rows; the columns ``nvrq score`` writes for these metrics (``psnr``,
        ``nvrq:ENCODER``, ...), with the same values: pixel metrics compare the GT crop with
        the render crop bicubic-resized to the GT crop's size; NVRQ (paper Eq. 4) and NVRQ-CA
        (Eq. 5) compare the crops' encoder embeddings (docs/FORMATS.md §4).

    >>> gt = np.full((8, 8, 3), 100, np.uint8)
    >>> score_crops([gt], [gt + 1], metrics="psnr,mae").round(3).to_dict("records")
    [{'psnr': 48.131, 'mae': 1.0}]
    """
    plan = _plan(metrics, encoder, options)
    return _score(plan, _load(encoder, plan, cached=True), *_crop_inputs(plan, gt_crops, render_crops)[:3])


def score_frame(gt_image, render_image, gt_boxes, render_boxes, *, metrics, encoder=None,
                **options) -> pd.DataFrame:
    """Metrics of N box pairs of one GT image and one render image (see :func:`score_crops`).

    Parameters
    ----------
    gt_image, render_image : image
        numpy uint8 (H, W, 3) RGB, or a torch tensor (3, H, W) (uint8, or float in [0, 1]);
        the two may differ in size. A torch image is cut where it lies; only the crops are
        brought to the host. ``gt_image=None`` (and ``gt_boxes=None``) for no-reference metrics.
    gt_boxes, render_boxes : (N, 4) int
        Inclusive pixel boxes ``x0, y0, x1, y1`` (the pairs table's ``gt_*``/``r_*``
        columns). The GT image is cut once per distinct GT box, and those crops are shared.
        Or ``gt_boxes`` a :func:`project_boxes` table and ``render_boxes=None``: its kept rows
        are scored, and the result starts with their ``gt_visible`` and ``novel_visible``.

    Returns
    -------
    pandas.DataFrame
        One row per box pair, one column per metric (as :func:`score_crops`).

    >>> img = np.zeros((10, 10, 3), np.uint8)
    >>> score_frame(img, img + 2, [[0, 0, 3, 3], [0, 0, 3, 3]], [[0, 0, 3, 3], [2, 2, 9, 9]],
    ...             metrics=["mae"])["mae"].tolist()
    [2.0, 2.0]
    """
    plan = _plan(metrics, encoder, options)
    gt_boxes, render_boxes, vis = _box_table(gt_boxes, render_boxes)
    out = _score(plan, _load(encoder, plan, cached=True),
                 *_frame_inputs(plan, gt_image, render_image, gt_boxes, render_boxes)[:3])
    return out if vis is None else pd.concat([vis, out], axis=1)
