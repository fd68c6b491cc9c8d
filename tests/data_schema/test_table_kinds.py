"""A table's checks come from its kind, never from the label errors give it (issue 34, item 4:
"read_table chooses its validator from a human label string: a typo silently skips the
checks")."""

from __future__ import annotations

import ast
import warnings
from pathlib import Path

import pandas as pd
import pytest

from data_schema.errors import InputError
from data_schema.tables import TableKind, read_table

ROOT = Path(__file__).resolve().parents[2]


def _bad_pairs(tmp_path) -> Path:
    # a duplicated pair_id: check_pairs refuses it, a plain table does not look
    path = tmp_path / "pairs.csv"
    pd.DataFrame({"pair_id": ["a", "a"], "gt_x0": [0, 1]}).to_csv(path, index=False)
    return path


def test_the_kind_chooses_the_checks_and_the_label_only_names(tmp_path):
    path = _bad_pairs(tmp_path)
    with pytest.raises(InputError, match="pair_id"):
        read_table(path, kind=TableKind.PAIRS)
    with pytest.raises(InputError, match="pair_id"):  # any label: the kind's checks run
        read_table(path, kind=TableKind.PAIRS, what="my pairs")
    with pytest.raises(InputError, match="an existing my pairs file"):  # the label names it
        read_table(tmp_path / "absent.csv", kind=TableKind.PAIRS, what="my pairs")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert len(read_table(path, what="pairs tabel")) == 2  # a label: no kind, no checks


def test_the_old_label_spelling_still_checks_with_a_deprecation(tmp_path):
    path = _bad_pairs(tmp_path)
    with pytest.warns(DeprecationWarning, match="kind=TableKind.PAIRS"), pytest.raises(InputError):
        read_table(path, what="pairs table")


def test_no_caller_chooses_a_kind_by_its_label():
    """No module of the packages passes a TableKind's value as ``what``."""
    labels = {k.value for k in TableKind} - {TableKind.TABLE.value}
    found = []
    for pkg in ("data_schema", "nvrq", "annotate", "analysis"):
        for path in sorted((ROOT / pkg).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if isinstance(node, ast.keyword) and node.arg == "what" and \
                        isinstance(node.value, ast.Constant) and node.value.value in labels:
                    found.append(f"{path.relative_to(ROOT)}:{node.value.lineno}")
    assert not found, found
