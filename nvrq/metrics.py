"""The metric registry: every metric the toolkit computes or reads, known in one place.

Each entry says its direction (``higher_better``), its value range, whether it needs an image
encoder and whether it needs the GT crop (``reference``: full-reference metrics compare the GT
crop with the render crop; no-reference metrics score the render crop alone). ``analyze`` reads
directions from here; ``nvrq score`` computes the metrics from here. Encoder metrics are
*families*: the column ``nvrq:dinov2-small`` is the family ``nvrq`` with encoder
``dinov2-small`` (docs/FORMATS.md §4). A family with ``members`` (``pyiqa``) resolves each column
``pyiqa:NAME`` to its own entry through that function.

>>> metric_info("nvrq_ca:dinov2-reg-small").higher_better
True
>>> metric_info("not-a-metric") is None
True
>>> metric_info("niqe").reference, metric_info("psnr").reference
(False, True)
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

__all__ = ["MetricInfo", "REGISTRY", "register", "metric_info", "split_column", "direction",
           "DEFAULT_METRICS"]

#: the metrics ``nvrq score`` computes when ``--metrics`` is not given (``nvrq``/``nvrq_ca`` on
#: the chosen encoder)
DEFAULT_METRICS = ("psnr", "ssim", "nvrq", "nvrq_ca")


@dataclass(frozen=True)
class MetricInfo:
    """Metadata of one metric (or metric family, when ``needs_encoder`` or ``members``).

    ``fn`` is the per-crop function of an encoder-free metric. With ``reference`` (full
    reference): ``fn(gt, render) -> float``, ``gt`` and ``render`` uint8 RGB crops of equal shape
    (H, W, 3), the render crop resized to the GT crop's size. Without (no reference):
    ``fn(render) -> float`` on the raw render crop. Encoder families and proxies computed
    elsewhere have ``fn = None``. ``min_side``: the shorter crop side (px) below which the value
    is NaN; ``undefined``: when else it is NaN (run summaries count both). ``members(name)``:
    the entry of the column ``family:name`` of a family of external metrics.
    """

    name: str
    higher_better: bool
    value_range: tuple[float, float]
    needs_encoder: bool = False
    fn: Callable | None = None
    description: str = ""
    kind: str = "metric"  # {'metric', 'proxy'}
    reference: bool = True
    min_side: int = 1
    undefined: str = ""
    members: Callable[[str], MetricInfo] | None = None


REGISTRY: dict[str, MetricInfo] = {}


def register(info: MetricInfo) -> MetricInfo:
    """Add ``info`` to the registry (a name may be registered once)."""
    if info.name in REGISTRY:
        raise ValueError(f"metric {info.name!r} is already registered")
    REGISTRY[info.name] = info
    return info


def split_column(column: str) -> tuple[str, str | None]:
    """``'nvrq:dinov2-small'`` -> ``('nvrq', 'dinov2-small')``; ``'psnr'`` -> ``('psnr', None)``."""
    family, sep, encoder = str(column).partition(":")
    return (family, encoder) if sep else (family, None)


def metric_info(column: str) -> MetricInfo | None:
    """The registry entry behind a metrics-table column name, or ``None`` if unknown (for a
    ``members`` family: unknown to it, or its package not installed)."""
    family, member = split_column(column)
    info = REGISTRY.get(family)
    if info is not None and info.members is not None:
        if member is None:
            return None
        try:
            return info.members(member)
        except ValueError:  # InputError: unknown name, or the package is not installed
            return None
    if info is None or info.needs_encoder != (member is not None):
        return None
    return info


def direction(column: str) -> bool | None:
    """``True`` if higher is better, ``False`` if lower is better, ``None`` if unknown."""
    info = metric_info(column)
    return None if info is None else info.higher_better


register(MetricInfo("nvrq", True, (0.0, 1.0), needs_encoder=True,
                    description="NVRQ (paper Eq. 4): (cos(f_gt, f_render) + 1) / 2"))
register(MetricInfo("nvrq_ca", True, (0.0, 1.0), needs_encoder=True,
                    description="NVRQ-CA (paper Eq. 5): curve-adjusted NVRQ"))
# Downstream proxies (paper Eq. 6-10), written by `nvrq proxy`; analysed with --target.
register(MetricInfo("s_det", True, (0.0, 1.0), kind="proxy",
                    description="detection confidence on the render box (paper Eq. 6-8)"))
register(MetricInfo("imagenet_drop", False, (-1.0, 1.0), kind="proxy",
                    description="ImageNet top-class confidence drop GT -> render (paper Eq. 9)"))
register(MetricInfo("clip_drop", False, (-1.0, 1.0), kind="proxy",
                    description="CLIP zero-shot true-category confidence drop (paper Eq. 10)"))

# Weight-free pixel metrics on raw crops (docs/FORMATS.md §4; definitions in nvrq/pixel_metrics.py).
from nvrq import pixel_metrics as _px  # noqa: E402  (numpy + OpenCV; no torch)

register(MetricInfo("psnr", True, (0.0, float("inf")), fn=_px.psnr,
                    description="PSNR in dB over RGB, data range 255 (inf for identical crops)"))
register(MetricInfo("ssim", True, (-1.0, 1.0), fn=_px.ssim, min_side=_px.SSIM_MIN_SIDE,
                    description="SSIM (Gaussian 11x11, sigma 1.5), RGB channels averaged"))
register(MetricInfo("ms_ssim", True, (0.0, 1.0), fn=_px.ms_ssim, min_side=_px.SSIM_MIN_SIDE,
                    description="MS-SSIM on up to 5 scales (as many as the crop holds, weights "
                                "renormalised); NaN when the shorter crop side < 11 px"))
register(MetricInfo("gmsd", False, (0.0, 1.0), fn=_px.gmsd, min_side=_px.GMSD_MIN_SIDE,
                    description="gradient magnitude similarity deviation (Xue et al. 2014)"))
register(MetricInfo("mse", False, (0.0, 255.0 ** 2), fn=_px.mse,
                    description="mean squared error over RGB (0-255)"))
register(MetricInfo("mae", False, (0.0, 255.0), fn=_px.mae,
                    description="mean absolute error over RGB (0-255)"))

# No-reference metrics on the raw render crop (paper Table 1; definitions in nvrq/nr_metrics/).
from nvrq import nr_metrics as _nr  # noqa: E402
from nvrq.nr_metrics.brisque import MIN_SIDE as _BRISQUE_MIN_SIDE  # noqa: E402
from nvrq.nr_metrics.niqe import PATCH as _NIQE_PATCH  # noqa: E402
from nvrq.nr_metrics.piqe import MIN_SIDE as _PIQE_MIN_SIDE  # noqa: E402

register(MetricInfo("brisque", False, (-float("inf"), float("inf")), fn=_nr.brisque, reference=False,
                    min_side=_BRISQUE_MIN_SIDE,
                    undefined="a neighbour-product map without negative or without positive values: "
                              "no AGGD fit, as in the original release",
                    description="BRISQUE (Mittal et al. 2012), the original release's LIVE-trained SVR "
                                "(allmodel), as PyIQA / MATLAB compute it; not clipped (may leave 0-100)"))
register(MetricInfo("niqe", False, (0.0, float("inf")), fn=_nr.niqe, reference=False,
                    min_side=_NIQE_PATCH,
                    description="NIQE (Mittal et al. 2013), the original release's pristine model, as "
                                "MATLAB / basicsr compute it, every whole 96x96 block"))
register(MetricInfo("piqe", False, (0.0, 100.0), fn=_nr.piqe, reference=False, min_side=_PIQE_MIN_SIDE,
                    description="PIQE (Venkatanath et al. 2015), as MATLAB's piqe, 16x16 blocks"))
register(MetricInfo("entropy", True, (0.0, 8.0), fn=_nr.entropy, reference=False,
                    description="Shannon entropy (bits) of the 256-bin grey histogram, as MATLAB's entropy"))

# PyIQA's metrics, when pyiqa is installed (nvrq/pyiqa_bridge.py): columns pyiqa:NAME.
from nvrq import pyiqa_bridge as _pyiqa  # noqa: E402  (imports pyiqa only when a column is used)

register(MetricInfo("pyiqa", False, (-float("inf"), float("inf")), members=_pyiqa.metric_entry,
                    description="a PyIQA metric, pyiqa:NAME (pyiqa.create_metric(NAME)); direction "
                                "and reference from PyIQA"))
