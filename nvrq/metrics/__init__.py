"""Every metric fact in one package: what each metric is, and the functions that compute them.

- :mod:`~nvrq.metrics.info`: :class:`MetricInfo`, what the registry knows of one metric;
- :mod:`~nvrq.metrics.registry`: :data:`REGISTRY`, every metric and proxy registered once (name,
  direction, range, reference or not, encoder family, smallest crop side), and
  :data:`DEFAULT_METRICS`;
- :mod:`~nvrq.metrics.resolve`: the one resolver (:func:`column_info`, :func:`direction`,
  :func:`resolve_metrics`, :func:`encoder_for_metrics`, :func:`encoder_columns`,
  :func:`reference_columns`, :func:`needs_tau`, :func:`split_column`);
- :mod:`~nvrq.metrics.formulas`: NVRQ and NVRQ-CA (paper Eq. 4, 5) and the one tau check;
- :mod:`~nvrq.metrics.pixel`: the full-reference pixel metrics (PSNR, SSIM, MS-SSIM, GMSD, MSE,
  MAE); :mod:`~nvrq.metrics.no_reference`: BRISQUE, NIQE, PIQE, entropy on the render crop alone;
  :mod:`~nvrq.metrics.pyiqa_bridge`: PyIQA's metrics as columns ``pyiqa:NAME``.

Running them over crops and tables is :mod:`nvrq.scoring`. Importing this package loads numpy,
OpenCV and SciPy, never torch or pandas (``analyze`` reads directions from here).

>>> direction("psnr"), direction("gmsd"), column_info("niqe").min_side
(True, False, 96)
"""

from nvrq.metrics.formulas import W_LOW, check_tau, nvrq_ca, nvrq_similarity
from nvrq.metrics.info import MetricInfo
from nvrq.metrics.registry import DEFAULT_METRICS, REGISTRY, register
from nvrq.metrics.resolve import (
    column_info,
    direction,
    encoder_columns,
    encoder_for_metrics,
    needs_tau,
    reference_columns,
    resolve_metrics,
    split_column,
)

__all__ = ["MetricInfo", "REGISTRY", "register", "DEFAULT_METRICS", "column_info", "direction",
           "resolve_metrics", "encoder_for_metrics", "encoder_columns", "reference_columns",
           "needs_tau", "split_column", "nvrq_similarity", "nvrq_ca", "check_tau", "W_LOW"]
