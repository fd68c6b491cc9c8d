"""NVRQ core: scenes, geometry, GT/novel-view box pairs, crops, encoders and metrics."""

__version__ = "0.1.0"
