"""Running the metrics of :mod:`nvrq.metrics` over crops, in three layers:

- :mod:`~nvrq.scoring.core`: the in-memory batch core (:class:`~nvrq.scoring.core.CropBatch` ->
  metric columns; encoder inputs and model runs); it reads no file;
- :mod:`~nvrq.scoring.batches`: crops from a pairs table, each image decoded once, with the
  decode schedule beside the encoder;
- :mod:`~nvrq.scoring.driver`: the table driver behind ``nvrq score`` (progress bar, timing table,
  NaN counts).

The Python API (:mod:`nvrq.api`) and the engines' model actors use the core alone. This package
imports none of its modules itself, so importing the core does not bring in the driver's
progress bar or the decode threads.
"""

__all__: list[str] = []

# a submodule (e.g. nvrq.scoring.<module>) resolves on first use after a plain import of the package
from nvrq.lazy import lazy_exports  # noqa: E402

__getattr__, __dir__ = lazy_exports("nvrq.scoring", {}, globals())
