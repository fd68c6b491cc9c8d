"""Runnable examples (nvrq layer): small inputs made from data the user has, never shipped as data."""

# a submodule (e.g. nvrq.examples.<module>) resolves on first use after a plain import of the package
from nvrq.lazy import lazy_exports  # noqa: E402

__getattr__, __dir__ = lazy_exports("nvrq.examples", {}, globals())
