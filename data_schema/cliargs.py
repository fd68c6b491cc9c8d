"""One convention for the arguments of ``nvrq``, ``annotate`` and ``analyze`` (docs/FORMATS.md).

The rule, one per kind of argument:

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
  :data:`data_schema.tables.MIN_SIDE_PX`).

Old spellings keep working and print one ``note:`` line on stderr saying the new one.

>>> comma_list("psnr, ssim,,nvrq")
['psnr', 'ssim', 'nvrq']
>>> parse_wxh("960x540", option="--size")
(960, 540)
"""

from __future__ import annotations

import argparse
import contextlib
import re
import sys

from data_schema.errors import InputError, check_int, check_number

__all__ = ["comma_list", "parse_wxh", "CommaList", "DeprecatedFileOption", "DeprecatedSize", "deprecated",
           "allow_negative_lists", "NEGATIVE_LIST", "option_for", "flags_in_errors", "add_link_option",
           "int_arg", "number_arg", "checked_arg"]

#: A comma list of numbers that may start with a minus sign (``-3,-2,0``): a value, not an option.
NEGATIVE_LIST = re.compile(r"^-\d*\.?\d+([x,]\s*[-+]?\d*\.?\d+)*$")


def comma_list(text) -> list[str]:
    """``"a, b,,c"`` -> ``['a', 'b', 'c']`` (blank entries dropped)."""
    return [s.strip() for s in str(text).split(",") if s.strip()]


def parse_wxh(text, *, option: str) -> tuple[int, int]:
    """``"WxH"`` -> ``(W, H)``, both positive integers; InputError naming ``option`` otherwise."""
    parts = str(text).lower().split("x")
    if len(parts) != 2 or not all(p.strip().isdigit() and int(p) > 0 for p in parts):
        raise InputError(option, None, "WxH in positive pixels, e.g. 960x540", text)
    return int(parts[0]), int(parts[1])


def deprecated(old: str, new: str) -> None:
    """Print the one-line note for an old spelling that still works."""
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
    """An old spelling of a repeatable file option (``new``): appends to the same list, with a note."""

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
    """The command-line spelling (``--flag`` or ``POSITIONAL``) of the library parameter ``name``:
    the option of its alias (``aliases[name]``) where the chosen command has one, else of ``name``."""
    actions = _chosen_parser(parser, args)._actions
    for dest in dict.fromkeys(d for d in ((aliases or {}).get(name), name) if d):
        for action in actions:
            if action.dest == dest and action.help != argparse.SUPPRESS:
                if action.option_strings:
                    return max(action.option_strings, key=len)
                return str(action.metavar or action.dest).upper()
    return None


@contextlib.contextmanager
def flags_in_errors(parser: argparse.ArgumentParser, args, aliases: dict | None = None):
    """Library errors name the parameter (``tracks``); the CLI speaks of its flag (``--tracks``).

    Re-raises an :class:`InputError` whose ``param`` (or, in the former form without ``param``,
    whose ``where``) is a parameter of the chosen command with that parameter's option as its
    ``param``; ``aliases`` maps parameter names to argparse dests where they differ (an alias the
    chosen command lacks falls back to the parameter's own name, so ``{"weights": "yolo"}`` gives
    ``--yolo`` where that exists and ``--weights`` elsewhere).
    """
    try:
        yield
    except InputError as err:
        named = err.param is not None
        flag = option_for(parser, args, err.param if named else err.where, aliases)
        if flag is None:
            raise
        raise InputError(err.where if named else None, err.field, err.expected, err.got,
                         param=flag) from None


def allow_negative_lists(parser: argparse.ArgumentParser) -> None:
    """Let ``parser`` take values such as ``-3,-2,-1`` or ``-640x360`` (argparse reads a value
    that starts with ``-`` as an option unless it matches the negative-number pattern)."""
    parser._negative_number_matcher = NEGATIVE_LIST


def add_link_option(parser: argparse.ArgumentParser) -> None:
    """``--no-follow-links`` on a command that reads scene images: refuse image paths whose symbolic
    links lead outside the scene folder (the CLIs apply it with
    :func:`data_schema.tables.no_follow_links`; docs/FORMATS.md §7)."""
    parser.add_argument("--no-follow-links", action="store_true",
                        help="refuse images whose symbolic links lead outside the scene folder "
                             "(also NVRQ_NO_FOLLOW_LINKS=1; default: links are followed)")


def checked_arg(convert, check, what: str = "a number"):
    """An argparse ``type``: ``convert`` the text, then ``check`` the value (a library check that
    raises :class:`InputError`, such as :func:`~data_schema.errors.check_int`; its result, else
    the value, is the option's value); a failure is argparse's one-line usage error naming the
    option, with the check's ``expected`` text."""

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

    >>> number_arg(low=0, low_open=True)("nan")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: expected a positive number, got nan
    """
    return checked_arg(float, lambda v: check_number("value", v, low=low, high=high, low_open=low_open,
                                                   high_open=high_open), "a number")
