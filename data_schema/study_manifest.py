"""A rating study's ``manifest.json`` (docs/FORMATS.md §5): a typed, validated record with
``read`` and ``write``, as the other tables are.

Layer: data_schema (the vocabularies of :mod:`data_schema.vocab`; nothing of the toolkit).

``annotate build`` writes it once; every reader (the web app, ``annotate export`` / ``simulate``
/ ``serve``) reads it with :meth:`StudyManifest.read`, which checks each key readers rely on
and names the file and key that is wrong. Keys a newer writer adds are kept (``extra``) and
written back unchanged. A good/bad study has no ``design`` key (the design of the first
studies); a pairwise one has ``design`` and ``methods`` last.

>>> import tempfile, pathlib
>>> m = StudyManifest(study_id="s-1", seed=0, access=Access.OPEN, votes_per_item=5,
...                   training_order=["training:p1"], counts={"test": 3, "gold": 1})
>>> path = pathlib.Path(tempfile.mkdtemp()) / "manifest.json"
>>> m.write(path)
>>> back = StudyManifest.read(path)
>>> back == m, back.design, back.sampling
(True, <StudyDesign.BINARY: 'binary'>, <Sampling.UNIFORM: 'uniform'>)
>>> _ = path.write_text('{"format": "nvrq-study", "study_id": "s", "seed": 0, "access": "open",'
...                     ' "votes_per_item": "5", "training_order": [], "counts": {}}')
>>> StudyManifest.read(path)  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
data_schema.errors.InputError: .../manifest.json: votes_per_item: expected a JSON int, got '5'
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path

from data_schema.defaults import BREAK_EVERY, DISPLAY_SIZE
from data_schema.errors import InputError
from data_schema.tables import atomic_write_text
from data_schema.vocab import Access, Sampling, StudyDesign

__all__ = ["FORMAT", "StudyManifest"]

#: The manifest's ``format`` value.
FORMAT = "nvrq-study"

#: Keys every reader relies on, and their JSON types (checked first, in this order).
_REQUIRED = {"study_id": str, "seed": int, "access": str, "votes_per_item": int, "training_order": list,
             "counts": dict}
#: Optional keys and their JSON types (None is allowed for each).
_OPTIONAL = {"version": int, "participant_param": str, "completion_url": str, "break_every": int,
             "max_votes_per_item": int, "items_per_rater": int, "display_size": int, "image_format": str,
             "options": dict, "pairs": str, "metrics": list, "metric_columns": list,
             "attribute_columns": list, "view_columns": list, "method_columns": list,
             "scene_roots": dict, "offsets": list, "tracks": list, "gold_per_rater": int, "methods": list}


@dataclass(frozen=True)
class StudyManifest:
    """Every option and choice of one study (field names are the JSON keys).

    Required: ``study_id``, ``seed``, ``access`` (:class:`~data_schema.vocab.Access`),
    ``votes_per_item``, ``training_order`` (training item keys in the order shown) and
    ``counts`` (items per :class:`~data_schema.vocab.ItemKind`). The rest default to what a
    study made before the key existed means: ``design`` binary, ``sampling`` uniform,
    ``gold_per_rater`` None (every gold item), ``items_per_rater`` None (no cap),
    ``break_every`` 50, ``display_size`` 320.
    """

    study_id: str
    seed: int
    access: Access
    votes_per_item: int
    training_order: list = field(default_factory=list)
    counts: dict = field(default_factory=dict)
    version: int = 1
    participant_param: str | None = None
    completion_url: str | None = None
    break_every: int = BREAK_EVERY
    sampling: Sampling = Sampling.UNIFORM
    max_votes_per_item: int | None = None
    items_per_rater: int | None = None
    display_size: int = DISPLAY_SIZE
    image_format: str | None = None
    options: dict = field(default_factory=dict)
    pairs: str | None = None
    metrics: list = field(default_factory=list)
    metric_columns: list = field(default_factory=list)
    attribute_columns: list = field(default_factory=list)
    view_columns: list = field(default_factory=list)
    method_columns: list = field(default_factory=list)
    scene_roots: dict = field(default_factory=dict)
    offsets: list = field(default_factory=list)
    tracks: list = field(default_factory=list)
    gold_per_rater: int | None = None
    design: StudyDesign = StudyDesign.BINARY
    methods: list = field(default_factory=list)
    extra: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "access", Access(self.access))
        object.__setattr__(self, "sampling", Sampling(self.sampling))
        object.__setattr__(self, "design", StudyDesign(self.design))

    @classmethod
    def from_dict(cls, doc: dict, *, path: str | Path = "manifest.json") -> StudyManifest:
        """A manifest from its parsed JSON, checked (InputError naming ``path`` and the key).

        Parameters
        ----------
        doc : dict
            The parsed ``manifest.json``.
        path : str or pathlib.Path, optional
            The file named in errors.

        Returns
        -------
        StudyManifest
            The checked manifest.
        """
        if not isinstance(doc, dict) or doc.get("format") != FORMAT:
            raise InputError(path, "format", f"'{FORMAT}'",
                             repr(doc.get("format") if isinstance(doc, dict) else type(doc).__name__))
        for key, typ in _REQUIRED.items():
            if not isinstance(doc.get(key), typ) or isinstance(doc.get(key), bool):
                raise InputError(path, key, f"a JSON {typ.__name__}", repr(doc.get(key)))
        for key, typ in _OPTIONAL.items():
            value = doc.get(key)
            if value is not None and (not isinstance(value, typ) or isinstance(value, bool)):
                raise InputError(path, key, f"a JSON {typ.__name__} or null", repr(value))
        design = doc.get("design", StudyDesign.BINARY)
        if design not in tuple(StudyDesign):
            raise InputError(path, "design", "one of {'binary', 'pairwise'}", repr(design))
        if doc.get("access") not in tuple(Access):
            raise InputError(path, "access", "one of {'open', 'token', 'crowd'}", repr(doc["access"]))
        sampling, cap = doc.get("sampling") or Sampling.UNIFORM, doc.get("max_votes_per_item")
        if sampling not in tuple(Sampling) or Sampling(sampling).design not in (None, design):
            raise InputError(path, "sampling", "'uniform', 'active' (pairwise) or 'adaptive' (binary)",
                             repr(sampling))
        if sampling == Sampling.ADAPTIVE and (not isinstance(cap, int) or cap < doc["votes_per_item"]):
            raise InputError(path, "max_votes_per_item", "an integer >= votes_per_item", repr(cap))
        names = {f.name for f in dataclasses.fields(cls)} - {"extra"}
        known = {k: v for k, v in doc.items() if k in names and v is not None}
        extra = {k: v for k, v in doc.items() if k not in names and k != "format"}
        return cls(**{**known, "design": design, "sampling": sampling}, extra=extra)

    @classmethod
    def read(cls, path: str | Path) -> StudyManifest:
        """Read and check ``path`` (InputError naming the file and the key that is wrong).

        Parameters
        ----------
        path : str or pathlib.Path
            A study's ``manifest.json``.

        Returns
        -------
        StudyManifest
            The checked manifest.
        """
        path = Path(path)
        try:
            doc = json.loads(path.read_text(encoding="utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise InputError(path, None, "a JSON study manifest", f"unreadable JSON ({exc})") from None
        return cls.from_dict(doc, path=path)

    def to_dict(self) -> dict:
        """The JSON document, keys in the order ``annotate build`` writes them.

        Returns
        -------
        dict
            ``format`` first; a crowd study's panel keys after ``access``; a pairwise study's
            ``design`` and ``methods`` last (absent for a good/bad study), then ``extra``.
        """
        doc = {"format": FORMAT, "version": self.version, "study_id": self.study_id, "seed": self.seed,
               "access": str(self.access)}
        if self.access == Access.CROWD:
            doc.update(participant_param=self.participant_param, completion_url=self.completion_url)
        doc.update(votes_per_item=self.votes_per_item, break_every=self.break_every, sampling=str(self.sampling),
                   max_votes_per_item=self.max_votes_per_item, items_per_rater=self.items_per_rater,
                   display_size=self.display_size, image_format=self.image_format, options=self.options,
                   pairs=self.pairs, metrics=self.metrics, metric_columns=self.metric_columns,
                   attribute_columns=self.attribute_columns, view_columns=self.view_columns,
                   method_columns=self.method_columns, scene_roots=self.scene_roots, offsets=self.offsets,
                   tracks=self.tracks, counts=self.counts, gold_per_rater=self.gold_per_rater,
                   training_order=self.training_order)
        if self.design != StudyDesign.BINARY:
            doc.update(design=str(self.design), methods=self.methods)
        return {**doc, **self.extra}

    def write(self, path: str | Path) -> None:
        """Write the manifest atomically (a reader sees the old file or the whole new one).

        Parameters
        ----------
        path : str or pathlib.Path
            Where to write ``manifest.json``.
        """
        atomic_write_text(Path(path), json.dumps(self.to_dict(), indent=1, default=str))
