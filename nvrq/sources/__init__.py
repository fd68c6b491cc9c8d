"""Readers that turn external datasets into scene folders."""

# a submodule (e.g. nvrq.sources.<module>) resolves on first use after a plain import of the package
from nvrq.lazy import lazy_exports  # noqa: E402

__getattr__, __dir__ = lazy_exports("nvrq.sources", {}, globals())
