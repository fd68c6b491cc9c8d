"""Bad library options of the analysis raise the one error type (issue 26 item 7): an
InputError naming the parameter, with the allowed values, never a bare ValueError."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from analysis.tables.aggregate import aggregate
from analysis.tables.summary import summary_table
from data_schema.errors import InputError


def test_an_unknown_aggregation_names_the_method_parameter():
    votes = pd.DataFrame({"item_id": ["a", "a"], "rater_id": ["x", "y"], "vote": [1, 0]})
    with pytest.raises(InputError) as caught:
        aggregate(votes, method="vote-count")
    assert caught.value.param == "method"
    assert str(caught.value) == ("method: expected one of {'majority', 'dawid-skene', 'glad', 'mace'}, "
                                 "got 'vote-count'")


def test_an_unknown_ranking_names_the_rank_by_parameter():
    gvf = np.linspace(0, 1, 12)
    items = pd.DataFrame({"gvf": gvf, "majority_good": gvf >= 0.5, "psnr": 20 + 10 * gvf})
    with pytest.raises(InputError) as caught:
        summary_table(items, ["psnr"], {"psnr": True}, rank_by="auc", progress=False)
    assert caught.value.param == "rank_by"
    assert str(caught.value) == "rank_by: expected one of {'srcc', 'plcc', 'roc_auc'}, got 'auc'"
    # the allowed values still work (the check is not stricter than before)
    table = summary_table(items, ["psnr"], {"psnr": True}, rank_by="plcc", progress=False, n_boot=0)
    assert np.isclose(table.loc[0, "plcc"], 1.0)  # gvf is linear in psnr here: r = 1 by hand
