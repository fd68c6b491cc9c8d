"""Built-in synthetic driving scenes with known degradation (``nvrq synth``).

``generate_scene(out, SynthOptions(seed=..., ...))`` writes a docs/FORMATS.md §2 scene folder plus
``degradation.csv``; :mod:`nvrq.synth.artefacts` exposes the artefact functions.
"""

from nvrq.synth.generate import SynthOptions, generate_scene

__all__ = ["generate_scene", "SynthOptions"]

# a submodule (e.g. nvrq.synth.<module>) resolves on first use after a plain import of the package
from nvrq.lazy import lazy_exports  # noqa: E402

__getattr__, __dir__ = lazy_exports("nvrq.synth", {}, globals())
