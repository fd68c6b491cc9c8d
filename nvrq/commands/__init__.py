"""Subcommands of the ``nvrq`` CLI, one module each (see :mod:`nvrq.cli`)."""
