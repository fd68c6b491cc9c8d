"""Subcommands of the ``annotate`` CLI, one module each with ``register(sub)`` and ``run(args)``
(see :mod:`annotate.cli`).

Layer: commands (CLI shell) of ``annotate``.
"""
