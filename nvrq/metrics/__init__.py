"""Every metric fact in one package: what each metric is, and the functions that compute them.

- :mod:`~nvrq.metrics.info`: :class:`MetricInfo`, what the registry knows of one metric, and
  :class:`MetricKind`, what it consumes (``pair``, ``render``, ``encoder``, ``frame``, ``set``);
- :mod:`~nvrq.metrics.registry`: :data:`REGISTRY`, every metric and proxy registered once (name,
  direction, range, reference or not, encoder family, smallest crop side), and
  :data:`DEFAULT_METRICS`;
- :mod:`~nvrq.metrics.resolve`: the one resolver (:func:`column_info`, :func:`direction`,
  :func:`resolve_metrics`, :func:`named_encoder`, :func:`encoder_columns`,
  :func:`reference_columns`, :func:`needs_tau`, :func:`split_column`);
- :mod:`~nvrq.metrics.formulas`: NVRQ and NVRQ-CA (paper Eq. 4, 5) and the one tau check;
- :mod:`~nvrq.metrics.pixel`: the full-reference pixel metrics (PSNR, SSIM, MS-SSIM, GMSD, MSE,
  MAE); :mod:`~nvrq.metrics.no_reference`: BRISQUE, NIQE, PIQE, entropy on the render crop alone;
  :mod:`~nvrq.metrics.pyiqa_bridge`: PyIQA's metrics as columns ``pyiqa:NAME``.

Running them over crops and tables is :mod:`nvrq.scoring`. The names below are imported from
their modules on first use, so importing one light module (``nvrq.metrics.formulas``, as the
commands' parsers do) does not load the metrics themselves (OpenCV); the registry loads numpy
and OpenCV, never torch or pandas (``analyze`` reads directions from here).

>>> from nvrq.metrics import column_info, direction
>>> direction("psnr"), direction("gmsd"), column_info("niqe").min_side
(True, False, 96)
"""

from nvrq.lazy import lazy_exports

#: public name -> the module defining it
_EXPORTS = {
    **dict.fromkeys(("W_LOW", "check_tau", "nvrq_ca", "nvrq_similarity"), "nvrq.metrics.formulas"),
    **dict.fromkeys(("MetricInfo", "MetricKind"), "nvrq.metrics.info"),
    **dict.fromkeys(("DEFAULT_METRICS", "REGISTRY", "register"), "nvrq.metrics.registry"),
    **dict.fromkeys(("column_info", "direction", "encoder_columns", "named_encoder", "needs_tau",
                     "reference_columns", "resolve_metrics", "split_column", "metric_kind", "closest_metric",
                     "metric_names", "ColumnSpec", "column_specs"), "nvrq.metrics.resolve"),
}

__all__ = ["MetricInfo", "MetricKind", "metric_kind", "closest_metric", "metric_names", "ColumnSpec",
           "column_specs", "REGISTRY", "register", "DEFAULT_METRICS", "column_info", "direction",
           "resolve_metrics", "named_encoder", "encoder_columns", "reference_columns",
           "needs_tau", "split_column", "nvrq_similarity", "nvrq_ca", "check_tau", "W_LOW"]


__getattr__, __dir__ = lazy_exports("nvrq.metrics", _EXPORTS, globals())
