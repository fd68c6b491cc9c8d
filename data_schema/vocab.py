"""The closed vocabularies the files exchange: each a :class:`enum.StrEnum`, so a member *is*
its string (``ItemKind.GOLD == "gold"``, it writes and reads back unchanged in CSV and JSON)
while the code names it once.

Layer: data_schema (imports nothing of the toolkit).

- :class:`StudyDesign`: a study's design (manifest ``design``; docs/FORMATS.md §5, §11).
- :class:`Sampling`: where a study's votes go (manifest ``sampling``).
- :class:`ItemKind`: a study item's (and a rating's) ``kind`` (FORMATS §5).
- :class:`Access`: who may rate a study (manifest ``access``).
- :class:`Side`: the side of the pairwise rating page a render is shown on (votes' ``side_a``).
- :class:`Answer`: a pairwise answer in A/B terms (votes' ``choice``).

>>> ItemKind.GOLD == "gold", str(StudyDesign.PAIRWISE), Sampling("active") is Sampling.ACTIVE
(True, 'pairwise', True)
>>> Sampling.ACTIVE.design, Sampling.UNIFORM.design
(<StudyDesign.PAIRWISE: 'pairwise'>, None)
"""

from __future__ import annotations

from enum import StrEnum

__all__ = ["Access", "Answer", "ItemKind", "Sampling", "Side", "StudyDesign"]


class StudyDesign(StrEnum):
    """A study's design: good/bad votes on one render, or which of two renders is closer."""

    BINARY = "binary"
    PAIRWISE = "pairwise"


class Sampling(StrEnum):
    """Where a study's votes go: every test item equally, or by a sampler (one design each)."""

    UNIFORM = "uniform"
    ACTIVE = "active"
    ADAPTIVE = "adaptive"

    @property
    def design(self) -> StudyDesign | None:
        """The one design this scheme serves (None: any design)."""
        return {Sampling.ACTIVE: StudyDesign.PAIRWISE, Sampling.ADAPTIVE: StudyDesign.BINARY}.get(self)


class ItemKind(StrEnum):
    """A study item's kind, and the ``kind`` column of ratings.csv."""

    TEST = "test"
    GOLD = "gold"
    TRAINING = "training"
    REPEAT = "repeat"


class Access(StrEnum):
    """Who may rate a study: anyone who reaches it, raters with a token, or a crowd panel."""

    OPEN = "open"
    TOKEN = "token"
    CROWD = "crowd"


class Side(StrEnum):
    """The side of the pairwise rating page a render is shown on."""

    LEFT = "left"
    RIGHT = "right"


class Answer(StrEnum):
    """A pairwise answer in A/B terms: render A closer, render B closer, or can't tell."""

    A = "a"
    B = "b"
    TIE = "tie"
