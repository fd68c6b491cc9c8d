"""The column rule of analysis.tables.inputs and the metric-table join."""

import numpy as np
import pandas as pd
import pytest

from analysis.tables.inputs import classify_columns
from analysis.tables.labels import join_metrics
from data_schema.errors import InputError
from nvrq.metrics import direction


def _items():
    return pd.DataFrame(
        {
            "item_id": ["a", "b"],
            "gvf": [0.0, 1.0],
            "y_offset_m": [0.0, 1.0],
            "clip_id": ["c", "c"],
            "nvrq:enc": [0.1, 0.2],
            "s_det": [0.5, 0.6],
            "lighting": ["day", "night"],
            "mystery": [1.0, 2.0],
        }
    )


def test_column_roles_follow_the_written_rule():
    m, d, attrs, proxies = classify_columns(
        _items(), lower={"mystery"}, higher=set(), target=None, where="r"
    )
    assert m == ["nvrq:enc", "mystery"] and attrs == ["lighting"] and proxies == ["s_det"]
    assert d == {"nvrq:enc": direction("nvrq:enc"), "mystery": False}  # registry direction
    # a proxy used as the target is neither metric nor proxy
    m, _, _, proxies = classify_columns(
        _items(), lower={"mystery"}, higher=set(), target="s_det", where="r"
    )
    assert "s_det" not in m and proxies == []


@pytest.mark.parametrize(
    "lower, higher, needle",
    [
        (set(), set(), "mystery"),  # unknown direction names the column
        ({"mystery"}, {"mystery"}, "one direction"),
        ({"mystery", "typo"}, set(), "typo"),
        ({"mystery", "lighting"}, set(), "numeric"),
    ],
)
def test_column_errors(lower, higher, needle):
    with pytest.raises(InputError, match=needle):
        classify_columns(_items(), lower=lower, higher=higher, target=None, where="r")


def test_join_counts_unknown_ids_and_rejects_duplicate_columns():
    items = pd.DataFrame({"item_id": ["a", "b", "c"]})
    t1 = pd.DataFrame({"pair_id": ["b", "zz", "a"], "psnr": [2.0, 9.0, 1.0]})
    out, unknown, _ = join_metrics(items.copy(), [("m1.csv", t1)])
    np.testing.assert_array_equal(out["psnr"], [1.0, 2.0, np.nan])
    assert unknown == {"m1.csv": 1}
    with pytest.raises(InputError, match="also in m1.csv"):
        join_metrics(items.copy(), [("m1.csv", t1), ("m2.csv", t1)])


def _votes_file(tmp_path, rows):
    cols = ["item_id", "rater_id", "vote", "voted_at", "response_ms", "kind", "clip_id", "camera",
            "track_id", "label_class", "timestamp_us", "y_offset_m"]
    df = pd.DataFrame([dict(zip(cols, r, strict=True)) for r in rows])
    df.to_csv(tmp_path / "r.csv", index=False)
    return tmp_path / "r.csv"


def test_per_item_checks_name_the_first_item_in_the_file_at_its_last_row(tmp_path):
    from analysis.tables.inputs import read_ratings

    def row(item, rater, clip, kind="test"):
        return [item, rater, 1, "t", 900, kind, clip, "front", "t1", "car", 0, 1.0]

    # items "b" (lines 2 and 5) and "a" (lines 3 and 4) both have two clips; "b" comes first
    # in the file, so it is the one reported, at its last line (5), with its values in file order
    path = _votes_file(tmp_path, [row("b", "r1", "c1"), row("a", "r1", "c3"), row("a", "r2", "c4"),
                                  row("b", "r2", "c2")])
    with pytest.raises(InputError, match=r"line 5: clip_id: expected one clip_id per item \(item 'b'\), "
                                         r"got c1, c2"):
        read_ratings(path)
    # a second (rater, item, kind) row is reported at its own line (the first stays)
    path = _votes_file(tmp_path, [row("a", "r1", "c1"), row("b", "r1", "c1"), row("a", "r2", "c1"),
                                  row("a", "r1", "c1", "gold"), row("a", "r1", "c1")])
    with pytest.raises(InputError, match=r"line 6: .*a second row for rater 'r1', item 'a'"):
        read_ratings(path)
