"""The command layer of the ``nvrq`` CLI: one module per subcommand, ``register(sub)`` + ``run(args)``
(see :mod:`nvrq.cli`), and the option modules several commands share: :mod:`nvrq.commands.args`
(the argument conventions of ``nvrq``, ``annotate`` and ``analyze``) and
:mod:`nvrq.commands.engine_options`. No library module imports this package.

Layer: commands (CLI shell).
"""
