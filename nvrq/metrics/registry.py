"""The metric registry: every metric the toolkit computes or reads, registered in one place.

Each entry (:class:`~nvrq.metrics.info.MetricInfo`) says its direction (``higher_better``), its
value range, whether it needs an image encoder and whether it needs the GT crop (``reference``:
full-reference metrics compare the GT crop with the render crop; no-reference metrics score the
render crop alone). ``analyze`` reads directions from here; ``nvrq score`` computes the metrics
from here. Encoder metrics are *families*: the column ``nvrq:dinov2-small`` is the family ``nvrq``
with encoder ``dinov2-small`` (docs/FORMATS.md §4). A family with ``members`` (``pyiqa``)
resolves each column ``pyiqa:NAME`` to its own entry through that function. Questions about a
column (its entry, direction, encoder, tau) are answered by :mod:`nvrq.metrics.resolve`.

>>> REGISTRY["nvrq_ca"].higher_better, REGISTRY["niqe"].reference, REGISTRY["psnr"].reference
(True, False, True)
>>> sorted(n for n, i in REGISTRY.items() if i.kind == "proxy")
['clip_drop', 'imagenet_drop', 's_det']
"""

from __future__ import annotations

from functools import partial

from nvrq.choices import DEFAULT_METRICS  # the metrics of nvrq score without --metrics
from nvrq.metrics import formulas as _f
from nvrq.metrics import no_reference as _nr
from nvrq.metrics import pixel as _px  # numpy + OpenCV; no torch
from nvrq.metrics import pyiqa_bridge as _pyiqa  # imports pyiqa only when a column is used
from nvrq.metrics.info import MetricInfo, MetricKind
from nvrq.metrics.learned import dists as _ds  # numpy only; torch and the weights on first use
from nvrq.metrics.learned import lpips as _lp
from nvrq.metrics.learned import nvs_sqa as _sqa
from nvrq.metrics.no_reference.brisque import MIN_SIDE as _BRISQUE_MIN_SIDE
from nvrq.metrics.no_reference.brisque import _brisque
from nvrq.metrics.no_reference.entropy import _entropy
from nvrq.metrics.no_reference.niqe import PATCH as _NIQE_PATCH
from nvrq.metrics.no_reference.niqe import _niqe
from nvrq.metrics.no_reference.piqe import MIN_SIDE as _PIQE_MIN_SIDE
from nvrq.metrics.no_reference.piqe import _piqe

__all__ = ["REGISTRY", "register", "DEFAULT_METRICS"]


REGISTRY: dict[str, MetricInfo] = {}


def register(info: MetricInfo) -> MetricInfo:
    """Add ``info`` to the registry.

    Parameters
    ----------
    info : MetricInfo
        The entry; its ``name`` is the metric (or family) name, registered once.

    Returns
    -------
    MetricInfo
        ``info`` itself.

    Raises
    ------
    ValueError
        If a metric of that name is already registered (a programming error, not user input).
    """
    if info.name in REGISTRY:
        raise ValueError(f"metric {info.name!r} is already registered")
    REGISTRY[info.name] = info
    return info


register(MetricInfo("nvrq", True, (0.0, 1.0), needs_encoder=True, consumes=MetricKind.ENCODER,
                    from_similarity=_f._nvrq,
                    description="NVRQ (paper Eq. 4): (cos(f_gt, f_render) + 1) / 2"))
register(MetricInfo("nvrq_ca", True, (0.0, 1.0), needs_encoder=True, consumes=MetricKind.ENCODER,
                    from_similarity=_f._nvrq_ca, needs_tau=True,
                    description="NVRQ-CA (paper Eq. 5): curve-adjusted NVRQ"))
# Downstream proxies (paper Eq. 6-10), written by `nvrq proxy`; analysed with --target.
register(MetricInfo("s_det", True, (0.0, 1.0), kind="proxy",
                    description="detection confidence on the render box (paper Eq. 6-8)"))
register(MetricInfo("imagenet_drop", False, (-1.0, 1.0), kind="proxy",
                    description="ImageNet top-class confidence drop GT -> render (paper Eq. 9)"))
register(MetricInfo("clip_drop", False, (-1.0, 1.0), kind="proxy",
                    description="CLIP zero-shot true-category confidence drop (paper Eq. 10)"))

# Weight-free pixel metrics on raw crops (docs/FORMATS.md §4; definitions in nvrq/metrics/pixel.py).
register(MetricInfo("psnr", True, (0.0, float("inf")), fn=_px.psnr, compute=_px._psnr, consumes=MetricKind.PAIR,
                    description="PSNR in dB over RGB, data range 255 (inf for identical crops)"))
register(MetricInfo("ssim", True, (-1.0, 1.0), fn=_px.ssim, compute=_px._ssim, consumes=MetricKind.PAIR, min_side=_px.SSIM_MIN_SIDE,
                    description="SSIM (Gaussian 11x11, sigma 1.5), RGB channels averaged"))
register(MetricInfo("ms_ssim", True, (0.0, 1.0), fn=_px.ms_ssim, compute=_px._ms_ssim, consumes=MetricKind.PAIR, min_side=_px.SSIM_MIN_SIDE,
                    description="MS-SSIM on up to 5 scales (as many as the crop holds, weights "
                                "renormalised); NaN when the shorter crop side < 11 px"))
register(MetricInfo("gmsd", False, (0.0, 1.0), fn=_px.gmsd, compute=_px._gmsd, consumes=MetricKind.PAIR, min_side=_px.GMSD_MIN_SIDE,
                    description="gradient magnitude similarity deviation (Xue et al. 2014)"))
register(MetricInfo("mse", False, (0.0, 255.0 ** 2), fn=_px.mse, compute=_px._mse, consumes=MetricKind.PAIR,
                    description="mean squared error over RGB (0-255)"))
register(MetricInfo("mae", False, (0.0, 255.0), fn=_px.mae, compute=_px._mae, consumes=MetricKind.PAIR,
                    description="mean absolute error over RGB (0-255)"))

# Learned full-reference metrics from weights pip ships (nvrq/metrics/learned/; weights found by
# nvrq/metrics/learned/weights.py): computed batch by batch, each GT crop run once.
register(MetricInfo("lpips", False, (0.0, float("inf")), fn=_lp.lpips, consumes=MetricKind.PAIR,
                    batch=_lp.lpips_batch, prepare=partial(_lp.prepare, "lpips"), min_side=_lp.NETS["lpips"][2],
                    description="LPIPS 0.1 with AlexNet (Zhang et al. 2018, the authors' default), inputs "
                                "scaled to [-1, 1]; lower is better"))
register(MetricInfo("lpips_vgg", False, (0.0, float("inf")), fn=_lp.lpips_vgg, consumes=MetricKind.PAIR,
                    batch=partial(_lp.lpips_batch, metric="lpips_vgg"), prepare=partial(_lp.prepare, "lpips_vgg"),
                    min_side=_lp.NETS["lpips_vgg"][2],
                    description="LPIPS 0.1 with VGG16 (Zhang et al. 2018); lower is better"))
register(MetricInfo("stlpips", False, (0.0, float("inf")), fn=_lp.stlpips, consumes=MetricKind.PAIR,
                    batch=partial(_lp.lpips_batch, metric="stlpips"), prepare=partial(_lp.prepare, "stlpips"),
                    min_side=_lp.NETS["stlpips"][2],
                    description="ST-LPIPS (Ghildyal and Liu 2022), shift-tolerant LPIPS with its "
                                "anti-aliased AlexNet; lower is better"))
register(MetricInfo("dists", False, (0.0, 2.0), fn=_ds.dists, consumes=MetricKind.PAIR, batch=_ds.dists_batch,
                    prepare=_ds.prepare, min_side=_ds.MIN_SIDE_DISTS,
                    description="DISTS (Ding et al. 2020), VGG16 with L2 pooling, ImageNet "
                                "normalisation; lower is better"))

register(MetricInfo("nvs_sqa", True, (-float("inf"), float("inf")), fn=_sqa.nvs_sqa, compute=_sqa._nvs_sqa,
                    consumes=MetricKind.RENDER, reference=False, prepare=_sqa.prepare, min_side=_sqa.MIN_SIDE,
                    description="NVS-SQA (Qu et al. 2025), the nvs-sqa package's model and regressor, each "
                                "render crop scored as a set of one view; higher is better"))

# No-reference metrics on the raw render crop (paper Table 1; definitions in nvrq/metrics/no_reference/).
register(MetricInfo("brisque", False, (-float("inf"), float("inf")), fn=_nr.brisque, compute=_brisque, consumes=MetricKind.RENDER, reference=False,
                    min_side=_BRISQUE_MIN_SIDE,
                    undefined="a neighbour-product map without negative or without positive values: "
                              "no AGGD fit, as in the original release",
                    description="BRISQUE (Mittal et al. 2012), the original release's LIVE-trained SVR "
                                "(allmodel), as PyIQA / MATLAB compute it; not clipped (may leave 0-100)"))
register(MetricInfo("niqe", False, (0.0, float("inf")), fn=_nr.niqe, compute=_niqe, consumes=MetricKind.RENDER, reference=False,
                    min_side=_NIQE_PATCH,
                    description="NIQE (Mittal et al. 2013), the original release's pristine model, as "
                                "MATLAB / basicsr compute it, every whole 96x96 block"))
register(MetricInfo("piqe", False, (0.0, 100.0), fn=_nr.piqe, compute=_piqe, consumes=MetricKind.RENDER, reference=False, min_side=_PIQE_MIN_SIDE,
                    description="PIQE (Venkatanath et al. 2015), as MATLAB's piqe, 16x16 blocks"))
register(MetricInfo("entropy", True, (0.0, 8.0), fn=_nr.entropy, compute=_entropy, consumes=MetricKind.RENDER, reference=False,
                    description="Shannon entropy (bits) of the 256-bin grey histogram, as MATLAB's entropy"))

# PyIQA's metrics, when pyiqa is installed (nvrq/metrics/pyiqa_bridge.py): columns pyiqa:NAME.
register(MetricInfo("pyiqa", False, (-float("inf"), float("inf")), members=_pyiqa.metric_entry,
                    description="a PyIQA metric, pyiqa:NAME (pyiqa.create_metric(NAME)); direction "
                                "and reference from PyIQA"))
