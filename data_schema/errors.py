"""One error type for bad user input: it names the file, the field and what was expected.

Every command catches :class:`InputError` at the top level, prints ``str(err)`` as one
line and exits with status 2 (SPEC section 7).

>>> str(InputError("scene.json", "cameras.front.T_sensor_rig", "a 4x4 matrix", "3x4"))
'scene.json: cameras.front.T_sensor_rig: expected a 4x4 matrix, got 3x4'
"""

from __future__ import annotations

import sys

__all__ = ["InputError", "run_cli", "run_subcommand"]


class InputError(ValueError):
    """Bad user input. ``where`` is a file (or option), ``field`` the key/row/column inside it.

    The message is a single line: ``"{where}: {field}: expected {expected}, got {got}"``.
    """

    def __init__(self, where: object, field: str | None, expected: str, got: object = None):
        self.where = str(where)
        self.field = field
        self.expected = expected
        self.got = got
        parts = [self.where]
        if field:
            parts.append(str(field))
        msg = ": ".join(parts) + f": expected {expected}"
        if got is not None:
            got_s = str(got).replace("\n", " ")
            if len(got_s) > 120:
                got_s = got_s[:117] + "..."
            msg += f", got {got_s}"
        super().__init__(msg)


def run_cli(main, argv=None) -> int:
    """Run ``main(argv)``; turn an :class:`InputError` into one stderr line and exit status 2."""
    try:
        rc = main(argv)
    except InputError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    return int(rc or 0)


def run_subcommand(build_parser, argv=None) -> int:
    """Parse ``argv`` with ``build_parser()`` and run the chosen subcommand's ``func(args)``
    (set by its ``set_defaults``) under :func:`run_cli`."""

    def dispatch(args_list):
        args = build_parser().parse_args(args_list)
        return args.func(args)

    return run_cli(dispatch, argv)
