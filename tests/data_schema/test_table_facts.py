"""The facts every table shares are defined once, in data_schema (issue 26 item 5): which
methods a table holds, the object-view key and a table's header. The AST scans find each
fact's single definition; the behaviour tests compare the users of a fact with each other
and with a hand-built table."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from analysis.methods import compared_methods, object_codes
from annotate.pairwise import study_methods
from data_schema.datasets import table_columns
from data_schema.errors import InputError
from data_schema.methods import method_columns, table_methods
from data_schema.tables import OBJECT_COLUMNS, pair_ids

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("data_schema", "nvrq", "annotate", "analysis")


def _modules():
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            yield path.relative_to(ROOT).as_posix(), ast.parse(path.read_text(encoding="utf-8"))


def _definitions(name: str) -> list[str]:
    """Where ``name`` is defined: a function or class of that name, or a module-level assignment."""
    found = []
    for rel, tree in _modules():
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef) and node.name == name:
                found.append(rel)
        for node in tree.body:
            targets = node.targets if isinstance(node, ast.Assign) else \
                [node.target] if isinstance(node, ast.AnnAssign) else []
            if any(isinstance(t, ast.Name) and t.id == name for t in targets):
                found.append(rel)
    return found


@pytest.mark.parametrize("name, home", [
    ("table_methods", "data_schema/methods.py"),
    ("OBJECT_COLUMNS", "data_schema/tables.py"),
    ("table_columns", "data_schema/datasets.py"),
    ("require_columns", "data_schema/tables.py"),
])
def test_each_table_fact_has_one_definition(name, home):
    assert _definitions(name) == [home]


def test_no_function_is_called_check_methods_any_more():
    # three functions of that name meant three things; each now says what it does
    assert _definitions("check_methods") == []


def test_no_module_spells_the_object_key_out_again():
    key = list(OBJECT_COLUMNS)
    copies = []
    for rel, tree in _modules():
        for node in ast.walk(tree):
            if isinstance(node, ast.Tuple | ast.List) and len(node.elts) == len(key) and all(
                    isinstance(e, ast.Constant) for e in node.elts) and [e.value for e in node.elts] == key:
                copies.append(f"{rel}:{node.lineno}")
    assert copies == ["data_schema/tables.py:" + str(_line_of("OBJECT_COLUMNS"))]


def _line_of(name: str) -> int:
    tree = ast.parse((ROOT / "data_schema" / "tables.py").read_text(encoding="utf-8"))
    return next(n.lineno for n in tree.body if isinstance(n, ast.Assign)
                and any(getattr(t, "id", None) == name for t in n.targets))


def _methods_table() -> pd.DataFrame:
    # two objects (track t1 and t2 at one frame), each rendered by three methods in a
    # lateral view; a GT-like row without a method
    rows = [("c", "front", t, 100, 1.0, m) for t in ("t1", "t2") for m in ("nerf", "3dgs", "zip")]
    rows.append(("c", "front", "t1", 100, 0.0, ""))
    return pd.DataFrame(rows, columns=[*OBJECT_COLUMNS, "y_offset_m", "method"])


def test_annotate_and_analysis_choose_among_the_same_methods():
    df = _methods_table()
    # by hand: the distinct non-empty names, sorted
    assert table_methods(df) == ["3dgs", "nerf", "zip"]
    assert compared_methods(df, where="items.csv") == table_methods(df)
    full = df[df["method"] != ""]  # a pairwise study needs a method on every row
    assert study_methods(full, None, where="pairs.csv") == table_methods(full)
    assert method_columns(df) == ["method"] and method_columns(df.drop(columns="method")) == []
    assert table_methods(df.drop(columns="method")) == []


def test_a_table_without_methods_is_refused_by_both_readers_naming_the_column():
    df = _methods_table().drop(columns="method")
    for call in (lambda: compared_methods(df, where="items.csv"),
                 lambda: study_methods(df, None, where="pairs.csv")):
        with pytest.raises(InputError, match=r"\.csv: column 'method': expected a method"):
            call()


def test_analysis_object_codes_pair_the_rows_that_share_a_pair_id_without_method():
    # the two object keys of the toolkit (analysis' integer codes, annotate's ids) agree:
    # rows get one code exactly when their single-method pair ids are equal
    rng = np.random.default_rng(0)
    n = 200
    df = pd.DataFrame({"clip_id": rng.choice(["a", "b"], n), "camera": rng.choice(["front", "left"], n),
                       "track_id": rng.choice(["t1", "t2", "t3"], n), "timestamp_us": rng.choice([0, 100000], n),
                       "y_offset_m": rng.choice([-1.0, 0.0, 2.0], n), "yaw_deg": 0.0})
    df.loc[df.index % 7 == 0, ["y_offset_m", "yaw_deg"]] = [0.0, 5.0]
    codes = object_codes(df, where="items")
    ids = pd.factorize(pd.Index(pair_ids(df)))[0]
    assert (pd.crosstab(codes, ids).astype(bool).sum(axis=1) == 1).all()
    assert (pd.crosstab(ids, codes).astype(bool).sum(axis=1) == 1).all()


def test_object_codes_name_the_missing_object_column():
    df = _methods_table().drop(columns="camera")
    with pytest.raises(InputError, match=r"^items: column 'camera': expected the columns clip_id, camera"):
        object_codes(df, where="items")


def test_table_columns_reads_the_header_of_csv_parquet_and_datasets(tmp_path):
    df = pd.DataFrame({"pair_id": ["a"], "psnr": [1.0], "ssim": [0.5]})
    df.to_csv(tmp_path / "m.csv", index=False)
    df.to_parquet(tmp_path / "m.parquet", index=False)
    part = tmp_path / "ds" / "clip_id=c1"
    part.mkdir(parents=True)
    df.to_parquet(part / "part-0.parquet", index=False)
    for path in (tmp_path / "m.csv", tmp_path / "m.parquet", tmp_path / "ds"):
        assert table_columns(path) == ["pair_id", "psnr", "ssim"], path
