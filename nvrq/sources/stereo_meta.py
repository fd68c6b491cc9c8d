"""The defaults of ``nvrq import stereo`` (:mod:`nvrq.sources.stereo`), kept light: the ``nvrq``
parser reads them for its help without importing NumPy or OpenCV."""

from __future__ import annotations

__all__ = ["MARGIN_PX", "ROW_TOLERANCE_PX", "UNKNOWN_CLASS"]

#: pixels added on every side of a cluster's point extent (its left box); also the largest
#: distance of a cluster's disparities from their median before it is split
MARGIN_PX = 6
#: the largest median |v_left - v_right| (pixels) of matching points of a rectified pair. The
#: Argoverse sample's pair measures 5.5 px (its rows drift by about 8.2 - 0.0052 v px), so the
#: default is loose; KITTI pairs measure below 1 px
ROW_TOLERANCE_PX = 8.0
#: the class of a box found in the disparity
UNKNOWN_CLASS = "unknown"
