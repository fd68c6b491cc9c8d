"""NVRQ core: scenes, geometry, GT/novel-view box pairs, crops, encoders and metrics.

The public Python API (docs/PYTHON.md) is exported here and imported on first use, so
``import nvrq`` itself loads nothing heavy:

- scoring in memory: :func:`score_crops`, :func:`score_frame`, :class:`Evaluator`,
  :func:`clear_encoder_cache` (:mod:`nvrq.api`); the scoring plan they, ``nvrq score`` and the
  engines share: :func:`resolve_plan` -> :class:`ScorePlan` (:mod:`nvrq.scoring.plan`);
- encoders: :class:`EncoderConfig`, :func:`load_encoder` (:mod:`nvrq.encoders`);
- geometry: :func:`project_boxes` (the ``nvrq pairs`` rule for one frame, :mod:`nvrq.pairs`),
  :func:`camera_from_model` and the camera classes (:mod:`nvrq.geometry.cameras`);
- rendering: :func:`render_plan` (the views to render as arrays: ``viewmats``, ``Ks``, sizes,
  paths; a :class:`RenderPlan`, :mod:`nvrq.render_plans`);
- the trust horizon: :func:`trust_horizon` on a table of per-object scores, with a
  :class:`Threshold` (:mod:`nvrq.horizon`);
- off-path metrics the field reports: :func:`nta_iou` and :class:`NTAIoU` (NTA-IoU of projected
  boxes against detections, :mod:`nvrq.proxies.nta_iou`), :func:`embed` (encoder features of
  images for FD/KID, :mod:`nvrq.sets`).

>>> import nvrq
>>> sorted(nvrq.__all__)[:3]
['DROP_REASONS', 'EncoderConfig', 'Evaluator']
"""

from __future__ import annotations

from nvrq.lazy import lazy_exports

__version__ = "0.1.0"

#: public name -> the module defining it
_EXPORTS = {
    "score_crops": "nvrq.api",
    "score_frame": "nvrq.api",
    "Evaluator": "nvrq.api",
    "clear_encoder_cache": "nvrq.api",
    "ScorePlan": "nvrq.scoring.plan",
    "resolve_plan": "nvrq.scoring.plan",
    "EncoderConfig": "nvrq.encoders.registry",
    "load_encoder": "nvrq.encoders.registry",
    "project_boxes": "nvrq.pairs",
    "DROP_REASONS": "nvrq.pairs",
    "camera_from_model": "nvrq.geometry.cameras",
    "PinholeCamera": "nvrq.geometry.cameras",
    "OpenCVPinholeCamera": "nvrq.geometry.cameras",
    "OpenCVFisheyeCamera": "nvrq.geometry.cameras",
    "FThetaCamera": "nvrq.geometry.cameras",
    "render_plan": "nvrq.render_plans",
    "RenderPlan": "nvrq.render_plans",
    "trust_horizon": "nvrq.horizon",
    "Threshold": "nvrq.horizon",
    "nta_iou": "nvrq.proxies.nta_iou",
    "NTAIoU": "nvrq.proxies.nta_iou",
    "embed": "nvrq.sets",
}

__all__ = sorted(_EXPORTS)


__getattr__, __dir__ = lazy_exports("nvrq", _EXPORTS, globals())
