"""Encoder runtimes: the torch model exported once to OpenVINO or ONNX Runtime, cached on disk.

Layer: nvrq core, encoders.

:func:`wrap_runtime` turns a loaded :class:`~nvrq.encoders.registry.TorchEncoder` into an
object with the same interface (``embed(uint8 (N, S, S, 3)) -> float32 (N, D)``, ``spec``)
that runs on ``runtime`` at ``precision``. The exported graph takes the uint8 crops and does
the normalisation and pooling itself, so nothing but the crops crosses into the runtime.
The proxy models (ImageNet classifier logits, CLIP's image tower) go the same way as an
:class:`ExportableModel`, which brings its own output and identity measure.

Cache (``cache_dir``, else ``$NVRQ_CACHE``, else ``~/.cache/nvrq``)::

    runtimes/ENCODER/WEIGHTS_HASH-RUNTIME-VERSION/   model.onnx | model.xml+bin, meta.json
                                                     int8-CALIB_HASH.{onnx,xml} (calibrate-runtime)

``WEIGHTS_HASH`` is the SHA-256 of the state dict (names, shapes, bytes); ``VERSION`` the
runtime's and torch's versions, so upgrading either re-exports. ``meta.json`` records the
identity check made at export: max |dNVRQ| against torch fp32 on :func:`identity_images`.

Default on CPU (``runtime='auto'``): the first of :data:`AUTO_ORDER` that exports and
passes the identity check (max |dNVRQ| <= :data:`IDENTITY_TOL`), else torch. Order by
measurement on the 2-core machine (see ``benchmarks/bench_score.py``): OpenVINO fp32 ran
DINOv2-S at 13.4-13.8 img/s against 9.7-11.5 for ONNX Runtime and 8.3-10.7 for torch, and
efficientnet-lite0 at 346-365 against 312-348 for ONNX Runtime and 150-180 for torch (its
allocator tuned, :mod:`nvrq.encoders.memory`; 50-65 without), batch 8 and 32.
``device='cuda'`` always uses torch.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from nvrq.encoder_specs import PRECISIONS, RUNTIMES, SUPPORTED, check_runtime_combo

__all__ = ["RUNTIMES", "PRECISIONS", "SUPPORTED", "AUTO_ORDER", "IDENTITY_TOL", "cache_root", "check_runtime_combo",
           "weights_hash", "identity_images", "max_nvrq_change", "RuntimeEncoder", "wrap_runtime",
           "export_dir", "runtime_version", "embed_graph", "exported", "GraphSpec", "ExportableModel",
           "exported_forward"]

AUTO_ORDER = ("openvino", "onnxruntime")
IDENTITY_TOL = 1e-5


def cache_root(cache_dir=None) -> Path:
    """``cache_dir``, else ``$NVRQ_CACHE``, else ``~/.cache/nvrq``.

    Parameters
    ----------
    cache_dir : str or Path, optional
        The cache folder.

    Returns
    -------
    Path
    """
    if cache_dir is not None:
        return Path(cache_dir)
    env = os.environ.get("NVRQ_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "nvrq"


def weights_hash(model) -> str:
    """SHA-256 (hex) of a torch module's state dict: names, dtypes, shapes and bytes.

    Parameters
    ----------
    model : torch.nn.Module
        Any torch module.

    Returns
    -------
    str
        64 hex digits.
    """
    import torch

    h = hashlib.sha256(type(model).__name__.encode())
    for name, t in sorted(model.state_dict().items()):
        t = t.detach().cpu().contiguous()
        h.update(f"{name}:{t.dtype}:{tuple(t.shape)}".encode())
        h.update(t.view(-1).view(torch.uint8).numpy().tobytes() if t.numel() else b"")
    return h.hexdigest()


def runtime_version(runtime: str) -> str:
    """The version tag of an export: ``'<runtime version>-torch<torch version>'``.

    Parameters
    ----------
    runtime : str
        ``{'openvino', 'onnxruntime'}``.

    Returns
    -------
    str
    """
    import torch

    if runtime == "openvino":
        import openvino
        ver = openvino.__version__.split("-")[0]
    else:
        import onnxruntime
        ver = onnxruntime.__version__
    return f"{ver}-torch{torch.__version__.split('+')[0]}"


def export_dir(spec_name: str, whash: str, runtime: str, cache_dir=None) -> Path:
    """The cache folder of one model exported to one runtime version.

    Parameters
    ----------
    spec_name : str
        The encoder (or :class:`GraphSpec`) name.
    whash : str
        The weights' SHA-256 hex digest.
    runtime : str
        ``{'openvino', 'onnxruntime'}``.
    cache_dir : str or Path, optional
        The cache folder.

    Returns
    -------
    Path
        ``<cache>/runtimes/<name>/<hash16>-<runtime>-<version>``.
    """
    return cache_root(cache_dir) / "runtimes" / spec_name / f"{whash[:16]}-{runtime}-{runtime_version(runtime)}"


def identity_images(size: int, n: int = 8, *, seed: int = 0) -> np.ndarray:
    """``n`` deterministic uint8 images (n, size, size, 3): smooth colour noise; image ``2k+1``
    is image ``2k`` blurred and noised, so consecutive pairs span similar and dissimilar.

    Parameters
    ----------
    size : int
        Image side, pixels.
    n : int, optional
        Number of images (even).
    seed : int, optional
        Seed of the noise.

    Returns
    -------
    (n, size, size, 3) uint8
    """
    import cv2

    rng = np.random.default_rng(seed)
    out = np.empty((n, size, size, 3), np.uint8)
    for k in range(0, n, 2):
        coarse = rng.uniform(0, 255, (max(2, size // (8 + 4 * (k % 5))),) * 2 + (3,)).astype(np.float32)
        a = cv2.resize(coarse, (size, size), interpolation=cv2.INTER_CUBIC)
        out[k] = a.clip(0, 255).astype(np.uint8)
        if k + 1 < n:
            b = cv2.GaussianBlur(a, (0, 0), 1 + k % 4) + rng.normal(0, 4 * (k % 7), a.shape)
            out[k + 1] = b.clip(0, 255).astype(np.uint8)
    return out


def max_nvrq_change(ref: np.ndarray, other: np.ndarray) -> float:
    """max |dNVRQ| over consecutive pairs (0,1), (2,3), ... of two embedding sets (N, D).

    Parameters
    ----------
    ref, other : (N, D) float32
        Embeddings of the same images, N even.

    Returns
    -------
    float
    """
    from nvrq.metrics.formulas import nvrq_similarity

    a = nvrq_similarity(ref[0::2], ref[1::2])
    b = nvrq_similarity(other[0::2], other[1::2])
    return float(np.max(np.abs(a - b))) if len(a) else 0.0


def embed_graph(encoder):
    """A torch module: uint8 NHWC crops -> embeddings, normalisation and pooling inside.

    ``encoder``: a :class:`~nvrq.encoders.registry.TorchEncoder`, or any object with its
    interface plus ``graph_output(model, pixel_values)`` (an :class:`ExportableModel`).

    Parameters
    ----------
    encoder : TorchEncoder or ExportableModel
        The model to wrap.

    Returns
    -------
    torch.nn.Module
        ``uint8 (B, S, S, 3) -> float32 (B, D)``, in eval mode.
    """
    import torch

    forward = getattr(encoder, "graph_output", None)
    if forward is None:
        def forward(model, x):
            return encoder._backend.embed_tokens(model, x, encoder.spec)

    class EmbedGraph(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.model = encoder.model
            self.register_buffer("mean", torch.tensor(encoder.spec.mean, dtype=torch.float32).view(1, 3, 1, 1))
            self.register_buffer("std", torch.tensor(encoder.spec.std, dtype=torch.float32).view(1, 3, 1, 1))

        def forward(self, images):
            x = images.permute(0, 3, 1, 2).float().div(255.0)
            return forward(self.model, (x - self.mean) / self.std)

    return EmbedGraph().eval()


@dataclass(frozen=True)
class GraphSpec:
    """What the exporter needs to know of a model that is not a registry encoder.

    Attributes
    ----------
    name : str
        Names the cache folder.
    input_size : int
        Input side ``S``, pixels.
    mean, std : (3,) float
        Normalisation of RGB in [0, 1].
    """

    name: str
    input_size: int
    mean: tuple[float, float, float]
    std: tuple[float, float, float]


class ExportableModel:
    """Any torch model's output on uint8 crops, exported and cached like an encoder.

    The proxy classifiers use it (the ImageNet logits, CLIP's projected image embedding):
    ``forward(model, pixel_values (B, 3, S, S)) -> (B, K)`` is the exported computation;
    ``identity = (meta key, measure(torch_out, runtime_out) -> float)`` replaces max |dNVRQ|
    as the export's identity check (the auto rule compares it with :data:`IDENTITY_TOL`).
    ``name`` names the cache folder (with the weights' hash), so it must differ from the
    registry encoder's name when the weights are the same (efficientnet-lite0's head).

    Parameters
    ----------
    name : str
        Names the cache folder.
    model : torch.nn.Module
        The model.
    input_size : int
        Input side ``S``, pixels.
    mean, std : (3,) float
        Normalisation of RGB in [0, 1].
    forward : callable
        ``forward(model, pixel_values (B, 3, S, S)) -> (B, K)``.
    identity : (str, callable)
        ``(meta key, measure(torch_out, runtime_out) -> float)``.
    device : str, optional
        A torch device.
    """

    def __init__(self, name: str, model, *, input_size: int, mean, std, forward, identity,
                 device: str = "cpu"):
        import torch

        self.spec = GraphSpec(name, int(input_size), tuple(mean), tuple(std))
        self.model, self.device = model, torch.device(device)
        self._forward, self.identity = forward, identity

    def graph_output(self, model, pixel_values):
        return self._forward(model, pixel_values)

    def embed(self, images: np.ndarray) -> np.ndarray:
        """The torch reference: outputs (B, K) float32 of uint8 RGB inputs (B, S, S, 3)."""
        import torch

        from nvrq.crops import normalised_tensor

        x = normalised_tensor(np.asarray(images), self.spec.mean, self.spec.std, device=self.device)
        with torch.inference_mode():
            return self._forward(self.model, x).float().cpu().numpy()


def _identity(encoder):
    """(meta key, measure) of the export's identity check: max |dNVRQ| unless the model says."""
    return getattr(encoder, "identity", None) or ("max_dnvrq_vs_torch", max_nvrq_change)


class _FixedPositions:
    """Position-embedding interpolation of a ViT computed once, outside the exported graph.

    The input size is fixed, so the interpolated table is a constant; computing it in torch
    keeps it exact and avoids ops the exporter lacks (DINOv2-reg's antialiased bicubic).
    """

    def __init__(self, model):
        self.mods = [m for m in model.modules() if callable(getattr(m, "interpolate_pos_encoding", None))]

    def __enter__(self):
        for m in self.mods:
            cache: dict = {}
            orig = m.interpolate_pos_encoding

            def fixed(embeddings, height, width, _orig=orig, _cache=cache):
                key = (int(embeddings.shape[1]), int(height), int(width))
                if key not in _cache:
                    _cache[key] = _orig(embeddings, height, width).detach().clone()
                return _cache[key]
            m.interpolate_pos_encoding = fixed
        return self

    def __exit__(self, *exc):
        for m in self.mods:
            del m.interpolate_pos_encoding  # back to the class's method


def _export_onnx(encoder, path: Path) -> None:
    import warnings

    import torch

    s = encoder.spec.input_size
    x = torch.zeros((2, s, s, 3), dtype=torch.uint8)
    graph = embed_graph(encoder)
    with warnings.catch_warnings(), torch.inference_mode(False), torch.no_grad(), \
            _FixedPositions(encoder.model):
        warnings.simplefilter("ignore")
        graph(x)  # fills the position tables outside the trace
        torch.onnx.export(graph, (x,), os.fspath(path), input_names=["images"], output_names=["embedding"],
                          dynamic_axes={"images": {0: "n"}, "embedding": {0: "n"}}, dynamo=False,
                          opset_version=17, verbose=False)


def _export(encoder, runtime: str, folder: Path) -> None:
    """Export ``encoder`` to ``folder`` (fp32) atomically and record the identity check."""
    folder.parent.mkdir(parents=True, exist_ok=True)
    print(f"exporting {encoder.spec.name} to {runtime} (once; cached in {folder})", file=sys.stderr)
    with tempfile.TemporaryDirectory(dir=folder.parent) as tmp:
        tmp = Path(tmp)
        _export_onnx(encoder, tmp / "model.onnx")
        if runtime == "openvino":
            import openvino as ov

            ov.save_model(ov.convert_model(os.fspath(tmp / "model.onnx")), os.fspath(tmp / "model.xml"),
                          compress_to_fp16=False)  # the default halves the weights
            (tmp / "model.onnx").unlink()
        ref = encoder.embed(images := identity_images(encoder.spec.input_size))
        got = _session(runtime, tmp, "fp32", threads=None, model_file=None)(images)
        key, measure = _identity(encoder)
        meta = {"encoder": encoder.spec.name, "runtime": runtime, "version": runtime_version(runtime),
                key: measure(ref, got),
                "max_abs_embedding_diff": float(np.max(np.abs(ref - got)))}
        (tmp / "meta.json").write_text(json.dumps(meta, indent=2))
        os.chmod(tmp, 0o755)
        try:
            os.replace(tmp, folder)  # atomic: a half-written export is never seen as done
        except OSError:  # another process exported it meanwhile; ours is discarded
            pass
        tmp.mkdir(exist_ok=True)  # so TemporaryDirectory's clean-up finds its folder


def _session(runtime: str, folder: Path, precision: str, *, threads, model_file):
    """A callable uint8 (N, S, S, 3) -> float32 (N, D) on the exported model in ``folder``."""
    if runtime == "openvino":
        import openvino as ov

        cfg = {"INFERENCE_PRECISION_HINT": "bf16" if precision == "bf16" else "f32",
               "PERFORMANCE_HINT": "LATENCY"}
        if threads:
            cfg["INFERENCE_NUM_THREADS"] = int(threads)
        core = ov.Core()
        compiled = core.compile_model(core.read_model(os.fspath(model_file or folder / "model.xml")), "CPU", cfg)
        request = compiled.create_infer_request()

        def run(images):
            return np.array(request.infer({0: np.ascontiguousarray(images)})[0], np.float32)
        return run
    import onnxruntime as ort

    opts = ort.SessionOptions()
    if threads:
        opts.intra_op_num_threads = int(threads)
    opts.inter_op_num_threads = 1
    sess = ort.InferenceSession(os.fspath(model_file or folder / "model.onnx"), opts,
                                providers=["CPUExecutionProvider"])

    def run(images):
        return np.asarray(sess.run(None, {"images": np.ascontiguousarray(images)})[0], np.float32)
    return run


class RuntimeEncoder:
    """An exported encoder (the :class:`~nvrq.encoders.registry.Encoder` protocol).

    ``runtime``, ``precision``, ``threads`` and ``device`` describe how it runs (written to
    the timing file); ``weights_hash`` identifies the weights (drift-check records).

    Parameters
    ----------
    spec : EncoderSpec or GraphSpec
        What is encoded.
    run : callable
        ``run(uint8 (B, S, S, 3)) -> float32 (B, D)``.
    runtime : str
        ``{'openvino', 'onnxruntime'}``.
    precision : str
        ``{'fp32', 'bf16', 'int8'}``.
    threads : int
        CPU threads.
    whash : str
        The weights' SHA-256 hex digest.
    meta : dict
        The export's ``meta.json``.
    """

    def __init__(self, spec, run, *, runtime, precision, threads, whash, meta):
        self.spec, self._run = spec, run
        self.runtime, self.precision, self.threads, self.device = runtime, precision, threads, "cpu"
        self.weights_hash, self.meta = whash, meta

    def embed(self, images: np.ndarray) -> np.ndarray:
        images = np.asarray(images)
        s = self.spec.input_size
        if len(images) == 0:
            return np.zeros((0, 0), np.float32)
        if images.dtype != np.uint8 or images.ndim != 4 or images.shape[1:] != (s, s, 3):
            raise ValueError(f"encoder {self.spec.name}: expected uint8 (B, {s}, {s}, 3), "
                             f"got {images.dtype} {images.shape}")
        return self._run(images)


def exported(encoder, runtime: str, *, cache_dir=None, whash: str | None = None):
    """(folder, meta) of ``encoder`` exported to ``runtime`` (exporting on first use).

    Parameters
    ----------
    encoder : TorchEncoder or ExportableModel
        The model, torch fp32.
    runtime : str
        ``{'openvino', 'onnxruntime'}``.
    cache_dir : str or Path, optional
        The cache folder.
    whash : str, optional
        The weights' hash, when already known.

    Returns
    -------
    folder : Path
        The export folder.
    meta : dict
        Its ``meta.json``.
    whash : str
        The weights' hash.
    """
    whash = whash or weights_hash(encoder.model)
    folder = export_dir(encoder.spec.name, whash, runtime, cache_dir)
    if not (folder / "meta.json").is_file():
        _export(encoder, runtime, folder)
    return folder, json.loads((folder / "meta.json").read_text()), whash


def exported_forward(graph, *, runtime: str = "auto", threads: int | None = None, cache_dir=None):
    """``(runtime, threads, run)`` for a proxy model's fp32 ``graph`` (:class:`ExportableModel`):
    the runtime :func:`wrap_runtime` chose, the CPU threads it runs on, and its forward function,
    or ``None`` where that is torch (the model's own forward).

    Parameters
    ----------
    graph : ExportableModel
        A proxy model, fp32.
    runtime : str, optional
        ``{'auto', 'torch', 'openvino', 'onnxruntime'}``.
    threads : int, optional
        CPU threads (default: all).
    cache_dir : str or Path, optional
        The cache folder.

    Returns
    -------
    runtime : str
    threads : int
    run : callable or None
        ``run(uint8 (B, S, S, 3)) -> (B, K)``; ``None`` on torch.
    """
    wrapped = wrap_runtime(graph, runtime=runtime, precision="fp32", threads=threads,
                           cache_dir=cache_dir)
    if wrapped is graph:  # torch: the model's own forward, on torch's threads
        import torch

        return "torch", threads or torch.get_num_threads(), None
    return wrapped.runtime, wrapped.threads, wrapped.embed


def wrap_runtime(encoder, *, runtime: str = "auto", precision: str = "fp32", threads: int | None = None,
                 cache_dir=None, model_file=None):
    """``encoder`` (torch, fp32) on ``runtime`` at ``precision``; see the module docstring.

    ``model_file``: a reduced-precision model made by ``nvrq calibrate-runtime`` (int8).
    On torch, ``encoder`` itself is returned.

    Parameters
    ----------
    encoder : TorchEncoder
        The encoder, torch fp32.
    runtime : str, optional
        ``{'auto', 'torch', 'openvino', 'onnxruntime'}``.
    precision : str, optional
        ``{'fp32', 'bf16', 'int8'}``.
    threads : int, optional
        CPU threads (default: all).
    cache_dir : str or Path, optional
        The cache folder.
    model_file : str or Path, optional
        A reduced-precision model from ``nvrq calibrate-runtime``.

    Returns
    -------
    Encoder
        A :class:`RuntimeEncoder`, or ``encoder`` itself on torch.
    """
    device = str(encoder.device)
    check_runtime_combo(runtime, precision, device)
    if runtime == "auto":
        runtime = _auto(encoder, precision, device, cache_dir)
    if runtime == "torch":
        return encoder
    folder, meta, whash = exported(encoder, runtime, cache_dir=cache_dir)
    if precision == "int8" and model_file is None:
        raise ValueError("int8 needs the calibrated model file from `nvrq calibrate-runtime`")
    run = _session(runtime, folder, precision, threads=threads, model_file=model_file)
    return RuntimeEncoder(encoder.spec, run, runtime=runtime, precision=precision,
                          threads=threads or os.cpu_count(), whash=whash, meta=meta)


def _auto(encoder, precision: str, device: str, cache_dir) -> str:
    """The first exact exported runtime (module docstring), else torch."""
    if not device.startswith("cpu"):
        return "torch"
    for rt in AUTO_ORDER:
        if (rt, precision) not in SUPPORTED:
            continue
        try:
            _, meta, _ = exported(encoder, rt, cache_dir=cache_dir)
        except ImportError:
            continue
        except Exception as exc:  # an export failure falls back, loudly
            print(f"{rt} export of {encoder.spec.name} failed ({type(exc).__name__}: {exc}); "
                  "trying the next runtime", file=sys.stderr)
            continue
        key = _identity(encoder)[0]
        if meta[key] <= IDENTITY_TOL or precision != "fp32":
            return rt
        print(f"{rt}: {key} {meta[key]:.2g} > {IDENTITY_TOL}; not used", file=sys.stderr)
    return "torch"
