"""Camera models, poses and 3D boxes (vectorised numpy).

Layer: nvrq core, geometry.
"""

# a submodule (e.g. nvrq.geometry.<module>) resolves on first use after a plain import of the package
from nvrq.lazy import lazy_exports  # noqa: E402

__getattr__, __dir__ = lazy_exports("nvrq.geometry", {}, globals())
