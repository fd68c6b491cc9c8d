"""Learned metrics from weights that pip ships, in plain torch (no torchvision): the
full-reference LPIPS (AlexNet, VGG16) and DISTS, and the no-reference NVS-SQA.

- :mod:`~nvrq.metrics.learned.weights`: the one place that finds, converts and caches the
  weights; :mod:`~nvrq.metrics.learned.safe_load` reads their files without running them;
- :mod:`~nvrq.metrics.learned.nets`: AlexNet and VGG16 run from those arrays;
- :mod:`~nvrq.metrics.learned.batch`: pairs grouped by shape, each GT crop run once;
- :mod:`~nvrq.metrics.learned.lpips`, :mod:`~nvrq.metrics.learned.dists`,
  :mod:`~nvrq.metrics.learned.nvs_sqa`: the metrics.

Importing this package loads numpy only; torch loads when a metric first runs.
"""

__all__ = ["weights", "safe_load", "nets", "batch", "lpips", "dists", "nvs_sqa"]
