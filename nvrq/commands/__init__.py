"""The command layer of the ``nvrq`` CLI: one module per subcommand, ``register(sub)`` + ``run(args)``
(see :mod:`nvrq.cli`), and :mod:`nvrq.commands.engine_options`. The argument conventions of
``nvrq``, ``annotate`` and ``analyze`` (:mod:`nvrq.cli_types`) and the options several commands
add alike (:mod:`nvrq.cli_options`) sit below this package, so the other CLIs need not import it. No library module imports this package.

Layer: commands (CLI shell).

A ``run`` returns the exit status; bad input raises :class:`~data_schema.errors.InputError`,
which :func:`nvrq.cli_types.run_cli` prints as one line with exit status 2.
"""
