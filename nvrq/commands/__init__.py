"""The command layer of the ``nvrq`` CLI: one module per subcommand, ``register(sub)`` + ``run(args)``
(see :mod:`nvrq.cli`), and the option modules several commands share: :mod:`nvrq.commands.args`
(the argument conventions of ``nvrq``, ``annotate`` and ``analyze``),
:mod:`nvrq.commands.shared_options` (options several commands add alike) and
:mod:`nvrq.commands.engine_options`. No library module imports this package.

Layer: commands (CLI shell).

A ``run`` returns the exit status; bad input raises :class:`~data_schema.errors.InputError`,
which :func:`nvrq.commands.args.run_cli` prints as one line with exit status 2.
"""
