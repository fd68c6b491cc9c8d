"""No-reference metrics on the render crop alone (docs/FORMATS.md §4): raw rectangular crops, no
resize, deterministic (every patch/block, no random sampling).

Each function takes ``render``, a uint8 (H, W, 3) RGB crop, and returns a float (NaN where the
metric is undefined for that crop, e.g. too small; see each module). Lower is better for all but
``entropy``.

- :func:`brisque` -- Mittal et al. 2012, the original release's LIVE-trained model (``allmodel``);
- :func:`niqe` -- Mittal et al. 2013, the original release's pristine model, 96x96 blocks;
- :func:`piqe` -- Venkatanath et al. 2015, as MATLAB's ``piqe``;
- :func:`entropy` -- MATLAB's ``entropy`` of the grey crop.
"""

from nvrq.metrics.no_reference.brisque import brisque
from nvrq.metrics.no_reference.entropy import entropy
from nvrq.metrics.no_reference.niqe import niqe
from nvrq.metrics.no_reference.piqe import piqe

__all__ = ["brisque", "niqe", "piqe", "entropy"]

# a submodule (e.g. nvrq.metrics.no_reference.<module>) resolves on first use after a plain import of the package
from nvrq.lazy import lazy_exports  # noqa: E402

__getattr__, __dir__ = lazy_exports("nvrq.metrics.no_reference", {}, globals())
