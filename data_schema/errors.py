"""One error type for bad user input: it names the file, the field and what was expected.

Every command catches :class:`InputError` at the top level, prints ``str(err)`` as one
line and exits with status 2 (docs/FORMATS.md §7).

>>> str(InputError("scene.json", "cameras.front.T_sensor_rig", "a 4x4 matrix", "3x4"))
'scene.json: cameras.front.T_sensor_rig: expected a 4x4 matrix, got 3x4'
"""

from __future__ import annotations

import argparse
import os
import sys

__all__ = ["InputError", "run_cli", "ArgumentParser"]


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
    # OpenCV would print its own "[ WARN ]" lines for unreadable images before our one-line
    # error; errors reach the user through InputError only (set before cv2 is imported)
    os.environ.setdefault("OPENCV_LOG_LEVEL", "ERROR")
    if "cv2" in sys.modules:  # already imported (in-process callers): set it at run time
        logging = getattr(getattr(sys.modules["cv2"], "utils", None), "logging", None)
        if logging is not None:
            logging.setLogLevel(logging.LOG_LEVEL_ERROR)
    try:
        rc = main(argv)
    except InputError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    except OSError as err:  # last resort: a file the command could not read or write
        where = err.filename or "file system"
        print(f"error: {where}: {err.strerror or type(err).__name__}", file=sys.stderr)
        return 2
    except SystemExit as exc:  # argparse (usage errors, --help) exits; report its status
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    return int(rc or 0)


class ArgumentParser(argparse.ArgumentParser):
    """``argparse.ArgumentParser`` whose usage errors are one stderr line and exit status 2.

    Subparsers made with ``add_subparsers`` inherit the class, so every subcommand of a CLI
    built on it reports a bad argument the same way as bad input (docs/FORMATS.md §7).
    """

    def error(self, message: str):
        msg = " ".join(str(message).split())
        self.exit(2, f"error: {self.prog}: {msg} (see {self.prog} --help)\n")

