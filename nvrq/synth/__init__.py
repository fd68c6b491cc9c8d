"""Built-in synthetic driving scenes with known degradation (``nvrq synth``).

``generate_scene(out, SynthOptions(seed=..., ...))`` writes a docs/FORMATS.md §2 scene folder plus
``degradation.csv``; :mod:`nvrq.synth.artefacts` exposes the artefact functions.
"""

from nvrq.synth.generate import SynthOptions, generate_scene

__all__ = ["generate_scene", "SynthOptions"]
