"""The test-result format: CSV and HDF5 files that read back losslessly."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pandas as pd
import pytest

from grainlab.errors import InputError
from grainlab.result import TestResult, read_test_result

FLOATS = [0.0, -0.0, 0.1, 1.0 / 3.0, 5e-324, 2.2250738585072014e-308, 1e-300,
          1.7976931348623157e308, -1e300, np.nan, np.pi, -123456.789]


def make_result(n: int = len(FLOATS), strings=None) -> TestResult:
    rng = np.random.default_rng(3)
    table = pd.DataFrame({
        "increment": np.arange(n, dtype=np.int64),
        "sigma_yy": np.asarray(FLOATS[:n], dtype=float),
        "eps_yy": rng.normal(size=n) * 1e-5,
        "n_sliding": np.array([2**62, -(2**62), 0, 1, -1, 7, 8, 9, 10, 11, 12, 13][:n],
                              dtype=np.int64),
        "failed": np.array([True, False] * (n // 2) + [True] * (n % 2)),
        "stage": pd.Series(
            (strings or ["isotropic", "", "shear", "a,b", 'quo"te', " lead", "nan", "NA",
                         "None", "é ü", "multi\nline", "x"])[:n],
            dtype=object,
        ),
    })
    snapshots = {
        "normal_force": rng.normal(size=(n, 5)),
        "stiffness": rng.normal(size=(n, 3, 3)).astype(np.float32),
        "flags": rng.integers(0, 2, size=(n, 4)).astype(bool),
    }
    snapshots["normal_force"][0, 0] = np.nan
    return TestResult.create(
        table,
        specimen={"kind": "demo", "radii_m": np.array([0.1, 0.05]),
                  "nested": {"level": [1, {"deep": np.float64(2.5)}, "text"],
                             "flag": np.bool_(True), "count": np.int64(4)}},
        load_path={"name": "path", "alpha_deg": 30.0},
        parameters={"tiny": 1e-300, "huge": 1e300, "empty": {}, "list": []},
        outcome={"status": "completed"},
        units={"n_sliding": "-"},
        snapshots=snapshots,
        snapshot_units={"normal_force": "N/m"},
        title="a demo",
    )


def assert_tables_identical(a: pd.DataFrame, b: pd.DataFrame) -> None:
    pd.testing.assert_frame_equal(a, b, check_exact=True)
    for column in a.columns:
        left, right = a[column].to_numpy(), b[column].to_numpy()
        if left.dtype.kind == "f":
            # bit for bit, signed zeros and NaN included
            np.testing.assert_array_equal(left.view(np.int64), right.view(np.int64))


def test_csv_round_trip_is_lossless(tmp_path):
    result = make_result()
    back = read_test_result(result.to_csv(tmp_path / "r.csv"))
    assert_tables_identical(result.table, back.table)
    assert back.metadata == result.metadata
    assert back.snapshots == {}  # the CSV keeps no snapshots
    assert back.table["stage"].tolist() == result.table["stage"].tolist()
    assert back.table["stage"].iloc[1] == ""


def test_hdf5_round_trip_is_lossless(tmp_path):
    result = make_result()
    back = read_test_result(result.to_hdf5(tmp_path / "r.h5"))
    assert result.equals(back)
    assert_tables_identical(result.table, back.table)
    assert back.metadata == result.metadata
    assert set(back.snapshots) == {"normal_force", "stiffness", "flags"}
    for name, array in result.snapshots.items():
        assert back.snapshots[name].dtype == array.dtype
        np.testing.assert_array_equal(back.snapshots[name], array)


def test_save_writes_both(tmp_path):
    result = make_result()
    csv_path, h5_path = result.save(tmp_path / "out", stem="run")
    assert csv_path.name == "run.csv" and h5_path.name == "run.h5"
    assert read_test_result(h5_path).equals(result)
    csv_back = read_test_result(csv_path)
    assert not csv_back.equals(result)  # snapshots are missing from the CSV
    assert_tables_identical(csv_back.table, result.table)




@pytest.mark.parametrize(
    "suffix",
    [".csv", ".h5"],
)
def test_default_string_column_keeps_empty_strings(tmp_path, suffix):
    """A column built from a plain list of str (pandas' default string dtype)."""
    table = pd.DataFrame({"stage": ["isotropic", "", "shear"], "q": [0.0, 1.0, 2.0]})
    result = TestResult.create(table, specimen={}, load_path={})
    back = read_test_result(
        result.to_csv(tmp_path / f"r{suffix}") if suffix == ".csv"
        else result.to_hdf5(tmp_path / f"r{suffix}")
    )
    assert back.table["stage"].tolist() == ["isotropic", "", "shear"]


def test_infinities_round_trip(tmp_path):
    table = pd.DataFrame({"q": [np.inf, -np.inf, 1.0]})
    result = TestResult.create(table, specimen={}, load_path={})
    for path in (result.to_csv(tmp_path / "r.csv"), result.to_hdf5(tmp_path / "r.h5")):
        np.testing.assert_array_equal(read_test_result(path).table["q"], table["q"])


def test_equals_detects_a_change(tmp_path):
    result = make_result()
    other = read_test_result(result.to_hdf5(tmp_path / "r.h5"))
    other.table.loc[3, "eps_yy"] = np.nextafter(other.table.loc[3, "eps_yy"], 1.0)
    assert not result.equals(other)
    other = read_test_result(result.to_hdf5(tmp_path / "r.h5"))
    other.snapshots["normal_force"][1, 1] += 1e-12
    assert not result.equals(other)


def test_units_and_metadata_fields():
    result = make_result()
    assert result.units["sigma_yy"] == "Pa"  # standard column
    assert result.units["eps_yy"] == "-"
    assert result.units["n_sliding"] == "-"  # given
    assert result.units["failed"] == ""  # unknown column
    assert result.metadata["format"] == "grainlab.test_result"
    assert result.metadata["sign_convention"].startswith("compression positive")
    assert result.specimen["nested"]["level"][1]["deep"] == 2.5
    assert isinstance(result.specimen["radii_m"], list)
    json.dumps(result.metadata)  # plain JSON, numpy scalars converted
    assert result.outcome == {"status": "completed"}
    np.testing.assert_array_equal(result.column("increment"), np.arange(len(FLOATS)))
    with pytest.raises(InputError, match="column"):
        result.column("nope")


def test_non_grainlab_csv_rejected(tmp_path):
    path = tmp_path / "plain.csv"
    pd.DataFrame({"a": [1, 2]}).to_csv(path, index=False)
    with pytest.raises(InputError, match="header"):
        read_test_result(path)


def test_non_grainlab_hdf5_rejected(tmp_path):
    path = tmp_path / "plain.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("x", data=np.arange(3))
    with pytest.raises(InputError):
        read_test_result(path)


def test_newer_format_version_rejected(tmp_path):
    path = make_result().to_csv(tmp_path / "r.csv")
    lines = path.read_text(encoding="utf-8").split("\n", 1)
    prefix = "# grainlab-test-result "
    meta = json.loads(lines[0][len(prefix):])
    meta["format_version"] = 99
    path.write_text(prefix + json.dumps(meta) + "\n" + lines[1], encoding="utf-8")
    with pytest.raises(InputError, match="format_version"):
        read_test_result(path)


@pytest.mark.parametrize("suffix", [".csv", ".h5"])
def test_version_1_discrete_tables_are_upgraded(tmp_path, suffix):
    """Version 1 discrete runs wrote q = (s1 - s3)/3, q_over_p and eps_p."""
    s1, s3 = np.array([1e4, 3e4]), np.array([1e4, 1e4])
    p = (s1 + 2 * s3) / 3
    old = pd.DataFrame({"sigma_1": s1, "sigma_3": s3, "p": p, "q": (s1 - s3) / 3,
                        "q_over_p": (s1 - s3) / 3 / p, "eps_p": [0.0, -0.01],
                        "eps_q": [0.0, 0.05]})
    result = TestResult.create(old, specimen={"kind": "discrete sample"}, load_path={},
                               units={"q_over_p": "-", "eps_p": "-"})
    result.metadata["format_version"] = 1
    path = result.to_csv(tmp_path / "r.csv") if suffix == ".csv" \
        else result.to_hdf5(tmp_path / "r.h5")
    back = read_test_result(path)
    table = back.table
    assert list(table.columns) == ["sigma_1", "sigma_3", "p", "q", "q_over_3", "q_over_trace",
                                   "eps_vol", "eps_q"]
    np.testing.assert_allclose(table["q"], s1 - s3)
    np.testing.assert_allclose(table["q_over_3"], (s1 - s3) / 3)
    np.testing.assert_allclose(table["q_over_trace"], (s1 - s3) / 3 / p)
    np.testing.assert_array_equal(table["eps_vol"], [0.0, -0.01])
    assert back.units["q"] == back.units["q_over_3"] == "Pa"
    assert back.units["eps_vol"] == "-" and "eps_p" not in back.units
    assert back.metadata["upgraded_from_format_version"] == 1


def test_version_1_tables_without_eps_p_read_unchanged(tmp_path):
    result = make_result()
    result.metadata["format_version"] = 1
    back = read_test_result(result.to_csv(tmp_path / "r.csv"))
    pd.testing.assert_frame_equal(back.table, result.table)


def test_missing_file_and_extension(tmp_path):
    with pytest.raises(InputError):
        read_test_result(tmp_path / "absent.csv")
    other = tmp_path / "r.txt"
    other.write_text("x", encoding="utf-8")
    with pytest.raises(InputError):
        read_test_result(other)


@pytest.mark.parametrize("shape", [(3,), (5, 2), (0, 4), ()])
def test_snapshot_with_wrong_first_axis_rejected(shape):
    table = pd.DataFrame({"q": [1.0, 2.0, 4.0, 8.0]})
    with pytest.raises(InputError, match="snapshots"):
        TestResult.create(table, specimen={}, load_path={},
                          snapshots={"forces": np.zeros(shape)})


def test_bad_dimension_rejected():
    with pytest.raises(InputError, match="dimension"):
        TestResult.create(pd.DataFrame({"q": [1.0]}), specimen={}, load_path={}, dimension=4)


def test_a_result_shows_a_summary_not_its_whole_table():
    """print(result), repr(result) and a notebook's view: what it is and its size, the table
    only as pandas truncates it."""
    n = 5000
    table = pd.DataFrame({"eps_zz": np.linspace(0.0, 0.05, n), "sigma_zz": np.full(n, 1e5)})
    result = TestResult.create(table, specimen={"kind": "discrete", "name": "300 <spheres>"},
                               load_path={"name": "triaxial_compression"},
                               outcome={"status": "failure", "reason": "strength reached"},
                               title="a triaxial test")
    text = str(result)
    assert "a triaxial test" in text and "triaxial_compression" in text
    assert "failure (strength reached)" in text and f"{n} rows x 2 columns" in text
    assert len(repr(result)) < 200 and repr(result).startswith("<TestResult")
    shown = result._repr_html_()
    assert "<table" in shown and "300 &lt;spheres&gt;" in shown  # escaped
    assert shown.count("<tr") < 100  # pandas' truncation, not 5000 rows
