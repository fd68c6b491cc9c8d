"""One convention for the arguments of ``nvrq``, ``annotate`` and ``analyze`` (docs/FORMATS.md).

Layer: a leaf of ``nvrq`` below its command layer (it imports :mod:`data_schema` only), so the
command layers of ``annotate`` and ``analyze`` import it without reaching into ``nvrq``'s commands.

The command layer of all three CLIs shares this module: their parser class, how a command runs
(:func:`run_cli`: one error line, exit status 2) and the argument rules. The rule, one per kind
of argument:

- **Names and numbers in a list** (metric names, cameras, offsets, rater ids, metric
  directions): one option whose value is a comma-separated list, e.g.
  ``--metrics psnr,ssim``, ``--offsets -3,-2,0``; repeating the option adds to the list.
- **Files**: an option named for the kind of file, taking one path; repeatable where several
  files combine (``--metrics-table``, ``--timing``). A metrics table is ``--metrics-table``
  because ``--metrics`` lists metric names.
- **Image sizes**: ``WxH`` in pixels, e.g. ``--size 960x540`` (a square such as a study's
  display crops is ``320x320``).
- **Numbers** are checked when the command line is parsed (``type=int_arg(...)`` /
  ``number_arg(...)``), before any file is read or model loaded: ``--batch-size 0`` ends at once.
- **Defaults shared by commands** come from one constant (e.g. ``--min-side`` from
  :data:`data_schema.defaults.MIN_SIDE_PX`).

Old spellings keep working and print one ``note:`` line on stderr saying the new one.

The library names its parameters (``tracks``); :func:`flags_in_errors` turns such a name in an
:class:`~data_schema.errors.InputError` into the chosen command's flag (``--tracks``).
The text form of a comma list is :func:`data_schema.text.comma_list` (the library splits
``metrics="psnr,ssim"`` with it too).

>>> parse_wxh("960x540", option="--size")
(960, 540)
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import re
import sys

from data_schema.errors import InputError, check_int, check_number
from data_schema.text import comma_list

__all__ = ["ArgumentParser", "command_parser", "run_cli", "add_version", "show_progress", "add_quiet_option", "parse_wxh", "CommaList", "DeprecatedFileOption", "DeprecatedSize",
           "deprecated", "allow_negative_lists", "NEGATIVE_LIST", "option_for", "flags_in_errors",
           "add_link_option", "int_arg", "number_arg", "checked_arg", "LazyHelp"]

#: A value that starts with one minus sign, not an option: a number or a size (``-3``, ``-.5``,
#: ``-640x360``, ``-3,abc``), or a comma list (``-a,b``; no option name holds a comma). The
#: command's own check then says what is wrong with it, as it does for ``3,abc``, instead of
#: argparse's "expected one argument".
NEGATIVE_LIST = re.compile(r"^-(?!-)(?:\.?\d|[^=]*,)")


class LazyHelp(str):
    """An option's help text made when the help is shown (e.g. from a registry that the parser
    must not import while it is built); as a string it is ``placeholder``.

    Parameters
    ----------
    render : callable
        ``render() -> str``: the help text.
    placeholder : str
        The text before it is rendered.

    Returns
    -------
    LazyHelp

    >>> print(LazyHelp(lambda: "metrics: psnr, ssim").render())
    metrics: psnr, ssim
    """

    def __new__(cls, render, placeholder: str = "see --help"):
        obj = super().__new__(cls, placeholder)
        obj.render = render
        return obj


class _HelpFormatter(argparse.HelpFormatter):
    """argparse's formatter, except that a comma-list option that still takes the deprecated
    space-separated form (:class:`CommaList` with ``nargs='+'``) is shown as the one list it
    is: ``--lower-better A,B``, not ``--lower-better A,B [A,B ...]``; a :class:`LazyHelp` is
    rendered when shown."""

    def _expand_help(self, action):
        if isinstance(action.help, LazyHelp):
            import copy

            action = copy.copy(action)
            action.help = action.help.render().replace("%", "%%")
        return super()._expand_help(action)

    def _format_args(self, action, default_metavar):
        if isinstance(action, CommaList) and action.nargs == "+":
            return self._metavar_formatter(action, default_metavar)(1)[0]
        return super()._format_args(action, default_metavar)


class ArgumentParser(argparse.ArgumentParser):
    """``argparse.ArgumentParser`` whose usage errors are one stderr line and exit status 2.

    Subparsers made with ``add_subparsers`` inherit the class, so every subcommand of a CLI
    built on it reports a bad argument the same way as bad input (docs/FORMATS.md §7). Its help
    shows a comma list as one ``A,B`` value (:class:`CommaList`), and a value that starts with a
    minus sign (``-3,-2``, ``-3,abc``) is taken as the value it is (:data:`NEGATIVE_LIST`).

    Parameters
    ----------
    *args, **kwargs
        Passed to ``argparse.ArgumentParser`` (``formatter_class`` defaults to the module's
        help formatter).
    """

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", _HelpFormatter)
        super().__init__(*args, **kwargs)
        allow_negative_lists(self)  # every (sub)command: ``--offsets -3,abc`` is a value

    def error(self, message: str):
        """Print ``error: PROG: MESSAGE (see PROG --help)`` as one line and exit with status 2.

        Parameters
        ----------
        message : str
            argparse's message (its line breaks and runs of spaces are folded).

        Raises
        ------
        SystemExit
            Always, with code 2.
        """
        msg = " ".join(str(message).split())
        self.exit(2, f"error: {self.prog}: {msg} (see {self.prog} --help)\n")


def command_parser(prog: str, description: str, modules) -> ArgumentParser:
    """The parser of a CLI made of subcommands, one module each.

    Parameters
    ----------
    prog : str
        The program's name (``nvrq``, ``annotate``).
    description : str
        What the program does, for ``--help``.
    modules : sequence of str
        The subcommand modules, in the order ``--help`` lists them; each has ``register(sub)``,
        which adds its parser to ``sub`` and sets ``func`` to its ``run(args)``.

    Returns
    -------
    ArgumentParser
        The parser; the chosen subcommand's name is ``args.command``.
    """
    parser = ArgumentParser(prog=prog, description=description)
    add_version(parser)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in modules:
        importlib.import_module(name).register(sub)  # a missing module is an install error
    return parser


def add_version(parser: argparse.ArgumentParser) -> None:
    """Add ``--version`` (prints ``PROG VERSION``, the toolkit's version, and exits 0).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        A program's top-level parser (``nvrq``, ``annotate``, ``analyze``).
    """
    from nvrq import __version__  # the package's own attribute: nothing heavy is imported

    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}",
                        help="print the program's version and exit")


def show_progress(args) -> bool:
    """Whether a command draws progress bars: not asked to be ``--quiet`` and standard error is
    a terminal (a log file or a pipe gets no bar redrawn line by line).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments (a command without ``--quiet`` counts as not quiet).

    Returns
    -------
    bool

    >>> import argparse, io, contextlib
    >>> with contextlib.redirect_stderr(io.StringIO()):
    ...     show_progress(argparse.Namespace(quiet=False))
    False
    """
    stream = sys.stderr
    return not getattr(args, "quiet", False) and bool(getattr(stream, "isatty", lambda: False)())


def add_quiet_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--quiet``, which turns off the progress bars :func:`show_progress` would draw.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The parser of a command that shows progress.
    """
    parser.add_argument("--quiet", action="store_true",
                        help="no progress bars (none is drawn when stderr is not a terminal)")


def run_cli(main, argv=None) -> int:
    """Run a command's ``main(argv)``; bad input becomes one stderr line and exit status 2.

    Parameters
    ----------
    main : callable
        ``main(argv) -> int | None``: parses ``argv`` and runs the command.
    argv : list of str, optional
        The arguments (default: ``sys.argv[1:]``, as argparse reads them).

    Returns
    -------
    int
        The exit status: ``main``'s (0 for None); 2 after an :class:`InputError` or an
        ``OSError`` (printed as ``error: ...``) or an argparse usage error; argparse's own status
        for ``--help``; 130 after Ctrl-C.
    """
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
    except KeyboardInterrupt as exc:  # a command may say what was kept and how to resume
        print("interrupted" + (f": {exc.args[0]}" if exc.args else ""), file=sys.stderr)
        return 130
    return int(rc or 0)


def parse_wxh(text, *, option: str) -> tuple[int, int]:
    """An image size ``"WxH"`` in pixels as ``(W, H)``.

    Parameters
    ----------
    text : object
        The size as given, e.g. ``"960x540"`` (``X`` also accepted).
    option : str
        The option named in the error, e.g. ``"--size"``.

    Returns
    -------
    tuple of int
        ``(width, height)``, both positive.

    Raises
    ------
    InputError
        When ``text`` is not two positive integers joined by ``x``.
    """
    parts = str(text).lower().split("x")
    if len(parts) != 2 or not all(p.strip().isdigit() and int(p) > 0 for p in parts):
        raise InputError(option, None, "WxH in positive pixels, e.g. 960x540", text)
    return int(parts[0]), int(parts[1])


def deprecated(old: str, new: str) -> None:
    """Print the one-line ``note:`` for an old spelling that still works.

    Parameters
    ----------
    old, new : str
        The spelling given and the one to use instead (both as typed, e.g. ``"--size 320"``).
    """
    print(f"note: {old} is deprecated; use {new}", file=sys.stderr)


class CommaList(argparse.Action):
    """``--opt a,b --opt c`` -> ``['a', 'b', 'c']``. With ``nargs='+'`` the old
    space-separated spelling ``--opt a b`` still works, with a deprecation note."""

    def __call__(self, parser, namespace, values, option_string=None):
        values = values if isinstance(values, list) else [values]
        if len(values) > 1:
            deprecated(f"{option_string} {' '.join(values)}", f"{option_string} {','.join(values)}")
        items = list(getattr(namespace, self.dest, None) or [])
        for v in values:
            items += comma_list(v)
        setattr(namespace, self.dest, items)


class DeprecatedFileOption(argparse.Action):
    """An old spelling of a repeatable file option (``new``): appends to the same list, with a note.

    Parameters
    ----------
    option_strings : list of str
        The old spellings.
    dest : str
        The list the values go to (shared with ``new``).
    new : str
        The current spelling, named in the note.
    **kwargs
        As for ``argparse.Action``.
    """

    def __init__(self, option_strings, dest, *, new: str, **kwargs):
        self.new = new
        super().__init__(option_strings, dest, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        deprecated(f"{option_string} FILE", f"{self.new} FILE")
        setattr(namespace, self.dest, [*(getattr(namespace, self.dest, None) or []), values])


class DeprecatedSize(argparse.Action):
    """``--size WxH`` of a square; the old spelling ``--size N`` still works, with a note."""

    def __call__(self, parser, namespace, values, option_string=None):
        text = str(values).strip()
        if text.isdigit():
            deprecated(f"{option_string} {text}", f"{option_string} {text}x{text}")
            text = f"{text}x{text}"
        setattr(namespace, self.dest, text)


def _chosen_parser(parser: argparse.ArgumentParser, args) -> argparse.ArgumentParser:
    """The (sub)parser that parsed ``args``: follow the chosen subcommand at every level."""
    while True:
        subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        if not subs or getattr(args, subs[0].dest, None) not in subs[0].choices:
            return parser
        parser = subs[0].choices[getattr(args, subs[0].dest)]


def option_for(parser: argparse.ArgumentParser, args, name: str, aliases: dict | None = None) -> str | None:
    """The command-line spelling of the library parameter ``name`` in the chosen command.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The CLI's top-level parser.
    args : argparse.Namespace
        What ``parser`` parsed (it says which subcommand was chosen).
    name : str
        A library parameter name, e.g. ``"batch_size"``.
    aliases : dict, optional
        Parameter name -> argparse dest where they differ (``{"scene_root": "scene"}``).

    Returns
    -------
    str or None
        The longest ``--flag`` of the option (its alias's where the chosen command has one, else
        its own name's), ``POSITIONAL`` for a positional argument, or None when the chosen
        command has no such argument (hidden options do not count).
    """
    actions = _chosen_parser(parser, args)._actions
    for dest in dict.fromkeys(d for d in ((aliases or {}).get(name), name) if d):
        for action in actions:
            if action.dest == dest and action.help != argparse.SUPPRESS:
                if action.option_strings:
                    return max(action.option_strings, key=len)
                return str(action.metavar or action.dest).upper()
    return None


#: a parameter named in a library hint: ``allow_same_class`` between backticks
_HINT_PARAMETER = re.compile(r"`([a-z][a-z0-9_]*)`")


@contextlib.contextmanager
def flags_in_errors(parser: argparse.ArgumentParser, args, aliases: dict | None = None):
    """Library errors name the parameter (``tracks``); the CLI speaks of its flag (``--tracks``).

    Re-raises an :class:`InputError` whose ``param`` (or, in the former form without ``param``,
    whose ``where``) is a parameter of the chosen command with that parameter's option as its
    ``param``; ``aliases`` maps parameter names to argparse dests where they differ (an alias the
    chosen command lacks falls back to the parameter's own name, so ``{"weights": "yolo"}`` gives
    ``--yolo`` where that exists and ``--weights`` elsewhere). A library hint names a parameter
    between backticks (``(or `allow_same_class`)``): the hint speaks of the option instead
    (``(or --allow-same-class)``); names without an option are left as written.

    Parameters
    ----------
    parser, args, aliases
        As for :func:`option_for`.

    Yields
    ------
    None
        The block runs inside; its :class:`InputError` is re-raised with flag names.

    Raises
    ------
    InputError
        The error raised inside the block, its parameter and hint names replaced by the flags
        :func:`option_for` finds (else unchanged).

    >>> p = argparse.ArgumentParser()
    >>> _ = p.add_argument("--allow-same-class", action="store_true")
    >>> with flags_in_errors(p, p.parse_args([])):
    ...     raise InputError("pairs.csv", None, "two classes (or `allow_same_class`; see `nvrq`)", "one")
    Traceback (most recent call last):
    ...
    data_schema.errors.InputError: pairs.csv: expected two classes (or --allow-same-class; see `nvrq`), got one
    """
    try:
        yield
    except InputError as err:
        named = err.param is not None
        flag = option_for(parser, args, err.param if named else err.where, aliases)
        expected = _HINT_PARAMETER.sub(lambda m: option_for(parser, args, m.group(1), aliases) or m.group(0),
                                       str(err.expected))
        if flag is None and expected == err.expected:
            raise
        if flag is None:
            raise InputError(err.where, err.field, expected, err.got, param=err.param) from None
        raise InputError(err.where if named else None, err.field, expected, err.got,
                         param=flag) from None


def allow_negative_lists(parser: argparse.ArgumentParser) -> None:
    """Let ``parser`` take values such as ``-3,-2,-1`` or ``-640x360``.

    argparse reads a value that starts with ``-`` as an option unless it matches its
    negative-number pattern; this sets that pattern to :data:`NEGATIVE_LIST`.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The (sub)command's parser.
    """
    parser._negative_number_matcher = NEGATIVE_LIST


def add_link_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--no-follow-links`` to a command that reads scene images.

    With it, image paths whose symbolic links lead outside the scene folder are refused (the CLIs
    apply it with :func:`data_schema.tables.no_follow_links`; docs/FORMATS.md §7).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    """
    parser.add_argument("--no-follow-links", action="store_true",
                        help="refuse images whose symbolic links lead outside the scene folder "
                             "(also NVRQ_NO_FOLLOW_LINKS=1; default: links are followed)")


def checked_arg(convert, check, what: str = "a number"):
    """An argparse ``type`` that converts the text, then checks the value with a library check.

    Parameters
    ----------
    convert : callable
        ``convert(text)``, e.g. ``int`` or ``float``; its ``TypeError``/``ValueError`` is a usage
        error.
    check : callable
        A library check that raises :class:`InputError`, such as
        :func:`~data_schema.errors.check_int`; its result, else the converted value, is the
        option's value.
    what : str, optional
        What is expected when ``convert`` fails (also argparse's name of the type).

    Returns
    -------
    callable
        ``parse(text)``, raising ``argparse.ArgumentTypeError("expected ..., got TEXT")``, which
        argparse reports as its one-line usage error naming the option.
    """

    def parse(text: str):
        try:
            value = convert(text)
        except (TypeError, ValueError):
            try:
                check(float(text))  # a number of the wrong kind says what was expected
            except (TypeError, ValueError, InputError) as err:
                expected = getattr(err, "expected", what)
                raise argparse.ArgumentTypeError(f"expected {expected}, got {text}") from None
            raise argparse.ArgumentTypeError(f"expected {what}, got {text}") from None
        try:
            checked = check(value)
        except InputError as err:
            raise argparse.ArgumentTypeError(f"expected {err.expected}, got {text}") from None
        return value if checked is None else checked

    parse.__name__ = what  # argparse names the type in some messages
    return parse


def int_arg(*, low: int = 1, high: int | None = None):
    """argparse ``type`` of an integer option in ``[low, high]`` (:func:`~data_schema.errors.check_int`).

    Parameters
    ----------
    low : int, optional
        Smallest value allowed (default 1: a positive count).
    high : int, optional
        Largest value allowed (default: none).

    Returns
    -------
    callable
        The ``type`` of :func:`checked_arg`.

    >>> int_arg(low=0)("3")
    3
    >>> int_arg()("0")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: expected a positive integer, got 0
    """
    return checked_arg(int, lambda v: check_int("value", v, low=low, high=high), "an integer")


def number_arg(*, low: float | None = None, high: float | None = None, low_open: bool = False,
               high_open: bool = False):
    """argparse ``type`` of a finite real option within the bounds
    (:func:`~data_schema.errors.check_number`; ``nan`` and ``inf`` are refused).

    Parameters
    ----------
    low, high : float, optional
        The bounds (default: none).
    low_open, high_open : bool, optional
        Whether the bound itself is excluded (default: included).

    Returns
    -------
    callable
        The ``type`` of :func:`checked_arg`.

    >>> number_arg(low=0, low_open=True)("nan")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: expected a positive number, got nan
    """
    return checked_arg(float, lambda v: check_number("value", v, low=low, high=high, low_open=low_open,
                                                   high_open=high_open), "a number")
