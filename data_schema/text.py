"""Text forms shared by the formats, the library and the command lines.

Layer: data_schema (file formats).

A comma list (``"psnr,ssim"``) is how a list of names travels as one string: in a command-line
option (:mod:`nvrq.cli_types`), in a library parameter that also takes a string
(``nvrq.api``'s ``metrics="psnr,ssim"``), and inside the grid texts of
:mod:`data_schema.perturbation` and :mod:`data_schema.methods`.

>>> comma_list("psnr, ssim,,nvrq")
['psnr', 'ssim', 'nvrq']
"""

from __future__ import annotations

__all__ = ["comma_list", "plural"]


def comma_list(text) -> list[str]:
    """Split a comma list into its stripped, non-blank items.

    Parameters
    ----------
    text : object
        The list as text (any object; ``str(text)`` is split), e.g. ``"a, b,,c"``.

    Returns
    -------
    list of str
        The items in order, white space stripped and blank entries dropped: ``['a', 'b', 'c']``.
    """
    return [s.strip() for s in str(text).split(",") if s.strip()]


def plural(n: int, noun: str, plural_form: str | None = None) -> str:
    """``n`` and ``noun``, the noun in the plural unless ``n`` is 1.

    Parameters
    ----------
    n : int
        The count.
    noun : str
        The singular noun.
    plural_form : str, optional
        The plural when it is not ``noun + 's'``.

    Returns
    -------
    str
        e.g. ``'1 camera'``, ``'3 cameras'``, ``'0 tracks'``.

    >>> plural(1, "camera"), plural(2, "frame"), plural(0, "track")
    ('1 camera', '2 frames', '0 tracks')
    """
    return f"{n} {noun if n == 1 else (plural_form or noun + 's')}"
