"""Reduced precision (bf16, int8) is opt-in and measured: drift checks and their records.

Layer: nvrq core, encoders.

``nvrq calibrate-runtime PAIRS --encoder E --runtime R --precision P`` embeds a sample of
crops in torch fp32 and in ``R``/``P`` (:func:`drift_stats`) and records the result
(:func:`write_record`) in ``CACHE/runtime_checks.json`` (``CACHE`` as in
:func:`nvrq.encoders.runtimes.cache_root`), keyed by encoder, runtime, precision and the
weights' hash. An int8 model is quantized there (:func:`quantize_int8`, OpenVINO: NNCF
post-training quantization on crops of the pairs; ONNX Runtime: dynamic quantization) and
the record points at it. ``load_encoder(..., precision=P)`` (so ``nvrq score``) refuses a
reduced precision without a record whose NVRQ Spearman reaches ``min_spearman`` (default
:data:`DEFAULT_MIN_SPEARMAN`) -- :func:`require_check`.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from data_schema.errors import InputError
from nvrq.encoders.runtimes import cache_root, exported, weights_hash

__all__ = ["DEFAULT_MIN_SPEARMAN", "MEASURED_SPEARMAN", "measured_text", "records_path", "record_key", "read_records", "write_record",
           "find_record", "require_check", "drift_stats", "quantize_int8", "pair_inputs", "check_runtime"]

DEFAULT_MIN_SPEARMAN = 0.999

#: NVRQ Spearman against torch fp32 measured per (encoder, runtime, precision) on 310 pairs of
#: a synthetic clip, 2 CPU cores with AVX-512 VNNI (``../shared/notes/perf-2026-12-01.md``;
#: docs/guides/walkthrough.md, "Reduced precision"; DINOv2-S with random weights). Your pairs and CPU may differ.
MEASURED_SPEARMAN = {
    ("dinov2-small", "openvino", "bf16"): 0.99999, ("efficientnet-lite0", "openvino", "bf16"): 0.998,
    ("dinov2-small", "openvino", "int8"): 0.99993, ("efficientnet-lite0", "openvino", "int8"): 0.967,
    ("dinov2-small", "onnxruntime", "int8"): 0.99994, ("efficientnet-lite0", "onnxruntime", "int8"): 0.887,
}
_RUNTIME_NAMES = {"openvino": "OpenVINO", "onnxruntime": "ONNX Runtime"}


def measured_text(precision: str, threshold: float = DEFAULT_MIN_SPEARMAN) -> str:
    """Where ``precision`` passed and failed the drift check in :data:`MEASURED_SPEARMAN`,
    with the numbers; ``''`` when nothing was measured at it.

    Parameters
    ----------
    precision : str
        ``'bf16'`` or ``'int8'`` (``'fp32'``: nothing measured).
    threshold : float, optional
        The NVRQ Spearman a run must reach to pass.

    Returns
    -------
    str
        One line.

    >>> measured_text("int8")  # doctest: +NORMALIZE_WHITESPACE
    'measured int8 (NVRQ Spearman vs torch fp32, 310 pairs of a synthetic clip): passes >= 0.999
    for dinov2-small (OpenVINO 0.99993, ONNX Runtime 0.99994); fails for efficientnet-lite0
    (OpenVINO 0.967, ONNX Runtime 0.887)'
    """
    by_enc: dict[bool, dict[str, list[str]]] = {True: {}, False: {}}
    for (enc, runtime, prec), s in MEASURED_SPEARMAN.items():
        if prec == precision:
            passed = all(v >= threshold for (e, _r, p), v in MEASURED_SPEARMAN.items()
                         if e == enc and p == prec)
            by_enc[passed].setdefault(enc, []).append(f"{_RUNTIME_NAMES[runtime]} {s:g}")
    if not by_enc[True] and not by_enc[False]:
        return ""
    parts = [f"{word} for " + ", ".join(f"{e} ({', '.join(v)})" for e, v in by_enc[ok].items())
             for ok, word in ((True, f"passes >= {threshold:g}"), (False, "fails")) if by_enc[ok]]
    return (f"measured {precision} (NVRQ Spearman vs torch fp32, 310 pairs of a synthetic clip): "
            + "; ".join(parts))


def records_path(cache_dir=None) -> Path:
    """The drift-check records file, ``<cache>/runtime_checks.json``.

    Parameters
    ----------
    cache_dir : str or Path, optional
        The export cache (default: :func:`~nvrq.encoders.runtimes.cache_root`).

    Returns
    -------
    Path
    """
    return cache_root(cache_dir) / "runtime_checks.json"


def record_key(encoder_name: str, runtime: str, precision: str, whash: str) -> str:
    """``'dinov2-small|openvino|int8|<first 16 hex of the weights hash>'``.

    Parameters
    ----------
    encoder_name : str
        A registry encoder name.
    runtime : str
        ``{'openvino', 'onnxruntime', 'torch'}``.
    precision : str
        ``{'fp32', 'bf16', 'int8'}``.
    whash : str
        The weights' SHA-256 hex digest (:func:`~nvrq.encoders.runtimes.weights_hash`).

    Returns
    -------
    str
    """
    return f"{encoder_name}|{runtime}|{precision}|{whash[:16]}"


def read_records(cache_dir=None) -> dict:
    """Every drift-check record on file, by :func:`record_key` (empty when there is no file).

    Parameters
    ----------
    cache_dir : str or Path, optional
        The export cache whose ``runtime_checks.json`` is read.

    Returns
    -------
    dict
        ``{record_key: record}``, as written by :func:`write_record`.

    Raises
    ------
    InputError
        The records file is not valid JSON.
    """
    path = records_path(cache_dir)
    if not path.is_file():
        return {}
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except ValueError as exc:
        raise InputError(path, None, "a JSON object of drift-check records", f"invalid JSON ({exc})") from None


def write_record(record: dict, cache_dir=None) -> Path:
    """Add or replace ``record`` (needs ``key``) in the records file, atomically.

    Parameters
    ----------
    record : dict
        A record as :func:`check_runtime` returns it.
    cache_dir : str or Path, optional
        The export cache.

    Returns
    -------
    Path
        The records file.
    """
    path = records_path(cache_dir)
    path.parent.mkdir(parents=True, exist_ok=True)
    records = read_records(cache_dir)
    records[record["key"]] = record
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        json.dump(records, f, indent=2, sort_keys=True)
    os.replace(tmp, path)
    return path


def find_record(encoder_name: str, runtime: str, precision: str, whash: str, cache_dir=None) -> dict | None:
    """The drift-check record of one encoder, runtime, precision and weights, if any.

    Parameters
    ----------
    encoder_name, runtime, precision, whash : str
        What the check was run on; looked up under their :func:`record_key`.
    cache_dir : str or Path, optional
        The export cache holding the records file (:func:`records_path`).

    Returns
    -------
    dict or None
        The record as :func:`check_runtime` built it (stored by :func:`write_record`); None
        when that combination was never checked.
    """
    return read_records(cache_dir).get(record_key(encoder_name, runtime, precision, whash))


def require_check(encoder, *, runtime: str, precision: str, cache_dir=None,
                  min_spearman: float | None = None) -> Path | None:
    """The model file of a passing drift check of ``encoder`` at ``runtime``/``precision``
    (``None`` for bf16, which needs no file); :class:`InputError` saying how to run one.

    Parameters
    ----------
    encoder : TorchEncoder
        The encoder, torch fp32.
    runtime : str
        ``{'openvino', 'onnxruntime', 'torch'}``.
    precision : str
        ``{'bf16', 'int8'}``.
    cache_dir : str or Path, optional
        The export cache.
    min_spearman : float, optional
        The NVRQ Spearman the check must have reached (default :data:`DEFAULT_MIN_SPEARMAN`).

    Returns
    -------
    Path or None
        The reduced-precision model file (``None`` for bf16).

    Raises
    ------
    InputError
        No passing check on record.
    """
    threshold = DEFAULT_MIN_SPEARMAN if min_spearman is None else float(min_spearman)
    name = encoder.spec.name
    rec = find_record(name, runtime, precision, weights_hash(encoder.model), cache_dir)
    how = (f"`nvrq calibrate-runtime` on pairs of your data first (from Python: {__name__}.check_runtime, "
           "then write_record)")
    if rec is None:
        raise InputError(param="precision", expected=f"a drift check on record for {name} {runtime}/{precision}: "
                         f"{how}", got="none")
    if not rec["nvrq_spearman"] >= threshold:
        raise InputError(param="precision",
                         expected=f"NVRQ Spearman >= {threshold} (`min_spearman`) against fp32 for {name} "
                         f"{runtime}/{precision} (or a new drift check on other pairs: {how})",
                         got=f"{rec['nvrq_spearman']:.5f} on record")
    model_file = rec.get("model_file")
    if precision == "int8" and (not model_file or not Path(model_file).is_file()):
        raise InputError(param="precision", expected=f"the int8 model on record for {name}: {how}",
                         got=model_file or "none")
    return Path(model_file) if model_file else None


def drift_stats(ref_gt, ref_r, low_gt, low_r) -> dict:
    """Embeddings of the same pairs' GT and render crops, fp32 (``ref_*``) and reduced
    (``low_*``), (N, D) each -> mean/min cosine (per crop), NVRQ Spearman, max |dNVRQ|.

    Parameters
    ----------
    ref_gt, ref_r : (N, D) float32
        fp32 embeddings of the GT and render crops.
    low_gt, low_r : (N, D) float32
        Reduced-precision embeddings of the same crops.

    Returns
    -------
    dict
        ``mean_cosine``, ``min_cosine`` (over the 2N crops), ``nvrq_spearman`` (NaN when
        N < 3 or constant), ``max_dnvrq`` and ``n_pairs``.

    >>> e = np.eye(3)[[0, 1, 2]] + 0.1
    >>> d = drift_stats(e, e[::-1], e, e[::-1])
    >>> round(d["min_cosine"], 6), d["max_dnvrq"]
    (1.0, 0.0)
    """
    from scipy.stats import spearmanr  # here: `nvrq --help` reads this module's default

    from nvrq.metrics.formulas import nvrq_similarity

    ref, low = np.concatenate([ref_gt, ref_r]), np.concatenate([low_gt, low_r])
    cos = np.einsum("nd,nd->n", ref, low) / (np.linalg.norm(ref, axis=1) * np.linalg.norm(low, axis=1))
    s_ref, s_low = nvrq_similarity(ref_gt, ref_r), nvrq_similarity(low_gt, low_r)
    rho = spearmanr(s_ref, s_low).statistic if len(s_ref) > 2 and np.ptp(s_ref) > 0 else float("nan")
    return {"mean_cosine": float(np.mean(cos)), "min_cosine": float(np.min(cos)),
            "nvrq_spearman": float(rho), "max_dnvrq": float(np.max(np.abs(s_ref - s_low))),
            "n_pairs": int(len(s_ref))}


def quantize_int8(encoder, runtime: str, calib_images: np.ndarray, *, cache_dir=None) -> Path:
    """An int8 model of ``encoder`` on ``runtime`` in the export cache, calibrated on
    ``calib_images`` (uint8 (N, S, S, 3); OpenVINO only) -> its file.

    Parameters
    ----------
    encoder : TorchEncoder
        The encoder, torch fp32.
    runtime : str
        ``{'openvino', 'onnxruntime'}``.
    calib_images : (N, S, S, 3) uint8
        RGB calibration crops, ``S = spec.input_size``.
    cache_dir : str or Path, optional
        The export cache.

    Returns
    -------
    Path
        The int8 model file.
    """
    folder, _, _ = exported(encoder, runtime, cache_dir=cache_dir)
    digest = hashlib.sha256(np.ascontiguousarray(calib_images).tobytes()).hexdigest()[:12]
    if runtime == "onnxruntime":
        from onnxruntime.quantization import QuantType, quantize_dynamic

        out = folder / "int8-dynamic.onnx"
        if not out.is_file():
            tmp = folder / f".int8-{os.getpid()}.onnx"
            quantize_dynamic(os.fspath(folder / "model.onnx"), os.fspath(tmp), weight_type=QuantType.QInt8)
            os.replace(tmp, out)
        return out
    out = folder / f"int8-{digest}.xml"
    if not out.is_file():
        import nncf
        import openvino as ov

        model = ov.Core().read_model(os.fspath(folder / "model.xml"))
        vit = encoder.spec.backend in ("hf_vit", "segformer")
        q = nncf.quantize(model, nncf.Dataset([calib_images[i:i + 1] for i in range(len(calib_images))]),
                          subset_size=len(calib_images),
                          model_type=nncf.ModelType.TRANSFORMER if vit else None)
        tmp = folder / f".int8-{digest}-{os.getpid()}-{int(time.time())}.xml"
        ov.save_model(q, os.fspath(tmp), compress_to_fp16=False)
        os.replace(tmp.with_suffix(".bin"), out.with_suffix(".bin"))
        os.replace(tmp, out)
    return out


def pair_inputs(pairs, size: int, *, n: int, seed: int = 0, scene_root=None, base=None,
                where: str = "pairs") -> tuple[np.ndarray, np.ndarray]:
    """Encoder inputs (k, size, size, 3) of the GT and of the render crops of ``n`` pairs
    drawn without replacement (seeded; all pairs when there are fewer); each image decoded once.

    Parameters
    ----------
    pairs : str, Path or pandas.DataFrame
        A pairs table (docs/FORMATS.md §3).
    size : int
        Encoder input side ``S``, pixels.
    n : int
        How many pairs to draw.
    seed : int, optional
        Seed of the draw.
    scene_root, base : str or Path, optional
        Where image paths are resolved from.
    where : str, optional
        The table named in errors.

    Returns
    -------
    gt, render : (k, S, S, 3) uint8
        RGB encoder inputs, ``k = min(n, len(pairs))``.
    """
    from data_schema.tables import GT_BOX_COLUMNS, RENDER_BOX_COLUMNS, pair_boxes, pair_image_paths
    from nvrq.crops import cut_box, encoder_input, read_rgb

    rows = np.sort(np.random.default_rng(seed).permutation(len(pairs))[:n])
    sub = pairs.iloc[rows].reset_index(drop=True)
    out = []
    for col, box_cols in (("gt_path", GT_BOX_COLUMNS), ("render_path", RENDER_BOX_COLUMNS)):
        paths = pair_image_paths(sub, col, scene_root=scene_root, base=base, where=where)
        boxes = pair_boxes(sub, list(box_cols), where=where)
        images: dict = {}
        crops = np.empty((len(sub), size, size, 3), np.uint8)
        for i, (p, b) in enumerate(zip(paths, boxes, strict=True)):
            if p not in images:
                images = {p: read_rgb(p)}  # rows are sorted by pair, so images repeat in runs
            crops[i] = encoder_input(cut_box(images[p], b, where=f"{where}: pair {rows[i] + 2}"), size)
        out.append(crops)
    return out[0], out[1]


def check_runtime(encoder, gt: np.ndarray, render: np.ndarray, *, runtime: str, precision: str,
                  calib: np.ndarray | None = None, cache_dir=None, batch_size: int = 32) -> dict:
    """Drift of ``encoder`` (torch fp32) on ``runtime``/``precision`` over pairs of crops
    ``gt``/``render`` (uint8 (N, S, S, 3)); the record to store (see :func:`write_record`).

    ``calib``: crops the int8 quantization is calibrated on (default ``gt``).

    Parameters
    ----------
    encoder : TorchEncoder
        The encoder, torch fp32.
    gt, render : (N, S, S, 3) uint8
        RGB crops of the same pairs.
    runtime : str
        ``{'openvino', 'onnxruntime', 'torch'}``.
    precision : str
        ``{'fp32', 'bf16', 'int8'}``.
    calib : (M, S, S, 3) uint8, optional
        int8 calibration crops (default ``gt``).
    cache_dir : str or Path, optional
        The export cache.
    batch_size : int, optional
        Crops per forward pass.

    Returns
    -------
    dict
        The record: ``key``, the encoder, runtime, precision, :func:`drift_stats` and the
        model file.
    """
    from nvrq.encoders.runtimes import wrap_runtime

    model_file = None
    if precision == "int8":
        model_file = quantize_int8(encoder, runtime, gt if calib is None else calib, cache_dir=cache_dir)
    low = wrap_runtime(encoder, runtime=runtime, precision=precision, cache_dir=cache_dir,
                       model_file=model_file)

    def emb(enc, x):
        return np.concatenate([enc.embed(x[k:k + batch_size]) for k in range(0, len(x), batch_size)])

    stats = drift_stats(emb(encoder, gt), emb(encoder, render), emb(low, gt), emb(low, render))
    whash = weights_hash(encoder.model)
    return {"key": record_key(encoder.spec.name, runtime, precision, whash), "encoder": encoder.spec.name,
            "runtime": runtime, "precision": precision, "weights_hash": whash, **stats,
            "model_file": None if model_file is None else str(model_file),
            "measured_at": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
