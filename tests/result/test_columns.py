"""The column registry: one name, unit and meaning per column."""

from __future__ import annotations

import pandas as pd

from grainlab.result import COLUMNS, TestResult, unit_of


def test_every_column_has_a_unit_and_a_meaning():
    for name, column in COLUMNS.items():
        assert column.unit and column.meaning, name
        assert name == name.strip() and " " not in name


def test_both_deviators_are_named_apart_and_no_ambiguous_ratio():
    assert "sigma_1 - sigma_3" in COLUMNS["q"].meaning
    assert "(sigma_1 - sigma_3)/3" in COLUMNS["q_over_3"].meaning
    assert COLUMNS["q"].unit == COLUMNS["q_over_3"].unit == "Pa"
    assert "q_over_p" not in COLUMNS  # q/p with which q? q_over_trace or eta
    assert "eps_p" not in COLUMNS and unit_of("eps_vol") == "-"


def test_results_are_stamped_with_the_registry_units():
    table = pd.DataFrame({"q": [1.0], "q_over_trace": [0.1], "eps_vol": [0.0], "mine": [2.0]})
    result = TestResult.create(table, specimen={}, load_path={}, units={"mine": "N"})
    assert result.units == {"q": "Pa", "q_over_trace": "-", "eps_vol": "-", "mine": "N"}
