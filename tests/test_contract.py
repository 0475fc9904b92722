"""The reproducibility contract (compendium.contract, notebooks/contract.toml): its classes and its declarations."""

import json
import math

import numpy as np
import pandas as pd
import pytest

from compendium.contract import (
    Contract,
    Converged,
    Error,
    Exact,
    Order,
    SolverPath,
    TableSpec,
    load_contract,
    parse_class,
    resolution,
    text_differences,
)
from compendium.guard import _markdown_blocks, read_csv, undeclared_committed_files
from compendium.paths import repo_root

ROOT = repo_root()


def test_classes_are_written_as_calls():
    assert parse_class("exact") == Exact()
    assert parse_class("converged(rtol=1e-4)") == Converged(rtol=1e-4)
    assert parse_class("error(floor=1e-9)") == Error(floor=1e-9)
    assert parse_class(" order ") == Order() and parse_class("path") == SolverPath()
    for bad, message in (("nearly", "unknown class"), ("error(flor=1)", "flor"), ("error(2)", "cannot read|unknown")):
        with pytest.raises(ValueError, match=message):
            parse_class(bad)
    with pytest.raises(ValueError, match="scale"):
        parse_class("converged(scale='row')")


def test_each_class_accepts_what_its_computation_supports_and_nothing_more():
    # exact: equal, NaN equals NaN
    assert Exact().accepts([1.0, math.nan], [1.0, math.nan]).all() and not Exact().accepts(22, 23)
    # converged: relative 1e-6 (+ the printed resolution); a fuel changed by 0.01 kg fails
    c = Converged()
    assert c.accepts(134.48198 * (1 + 1e-9), 134.48198) and not c.accepts(134.49198, 134.48198)
    assert c.accepts(134.483, 134.482, resolution=1e-3) and not c.accepts(134.492, 134.482, resolution=1e-3)
    assert c.accepts(2.5e-16, -2.08e-16), "a value at rounding level next to zero: within atol"
    assert Converged(scale="column").accepts(1e-7, 0.0, scale=1.0) and not c.accepts(1e-7, 0.0, scale=1e-3)
    # error: the magnitude (factor 2, same sign) or both below the floor
    e = Error(floor=1e-10)
    assert e.accepts(4.639e-8, 4.773e-8) and e.accepts(3.66e-15, 3.33e-15) and e.accepts(-1e-16, 5e-11)
    assert not e.accepts(1e-6, 3e-6) and not e.accepts(-1e-6, 1e-6)
    # continuous at the floor: a value below it counts as the floor
    assert e.accepts(4e-11, 1.12e-10) and not e.accepts(4e-11, 2.5e-10)
    # order: a tenth; path: a factor of 3 (+ 10)
    assert Order().accepts(5.41112, 5.41083) and not Order().accepts(4.6, 4.1)
    assert SolverPath().accepts([83, 19, 25], [51, 34, 8]).all() and not SolverPath().accepts(300, 51)


def test_resolution_is_one_unit_of_the_last_printed_digit():
    assert resolution("0.4466") == pytest.approx(1e-4)
    assert resolution("4.639151e-08") == pytest.approx(1e-14)
    assert resolution("5365") == 1 and resolution("1e-05") == pytest.approx(1e-5) and resolution("x") == 0


def test_a_column_resolves_what_its_format_writes():
    from compendium.contract import column_resolutions

    # %g drops trailing zeros: "0.5" of a 10-digit column is 0.5 to 10 digits, not to one decimal
    assert column_resolutions(["0.4466453337", "0.5", ""]) == pytest.approx([1e-10, 1e-10, 0.0])
    # a fixed-point column (a Markdown table's .3f) resolves its last decimal, whatever the value
    assert column_resolutions(["134.482", "0.004"]) == pytest.approx([1e-3, 1e-3])
    assert column_resolutions(["4.639151e-08", "1.2e+00"]) == pytest.approx([1e-14, 1e-6])


def test_text_is_compared_word_for_word_and_its_numbers_by_class():
    assert text_differences("J = 4.000000, t_f = 0.44665", "J = 4.000000, t_f = 0.44665") == []
    assert text_differences("t_f = 0.44666", "t_f = 0.44665") == []  # one unit of the last digit
    assert text_differences("t_f = 0.44675", "t_f = 0.44665")
    assert text_differences("4 segments", "4 meshes")
    assert text_differences("max |H| 7e-08", "max |H| 6e-08", Error()) == []


def test_a_table_declaration_names_its_key_status_and_classes():
    spec = TableSpec.from_toml(
        "runs",
        {
            "key": ["thrust_N"],
            "status": "converged",
            "exact": ["thrust_N", "converged"],
            "error(floor=1e-8)": ["norm_*"],
        },
    )
    assert spec.class_of("norm_S") == Error(floor=1e-8) and spec.class_of("fuel") is None
    assert spec.undeclared(["thrust_N", "fuel"]) == ["fuel"]
    with pytest.raises(ValueError, match="declared twice"):
        TableSpec.from_toml("t", {"exact": ["a"], "converged": ["a"]})
    with pytest.raises(ValueError, match="needs a class"):
        TableSpec.from_toml("t", {"key": ["a"], "converged": ["b"]})


def test_the_committed_contract_reads_and_declares_the_whole_published_record():
    contract = load_contract()
    notebooks = {p.stem for p in (ROOT / "notebooks").glob("*.ipynb")}
    assert set(contract.notebooks) == notebooks
    assert undeclared_committed_files(ROOT, contract) == []


def _columns(path):
    if path.suffix == ".csv":
        return list(read_csv(path).columns)
    if path.suffix == ".json":
        return list(json.loads(path.read_text()))
    return [c for kind, t in _markdown_blocks(path.read_text()) if kind == "table" for c in t.columns]


def test_every_column_of_every_committed_table_has_a_class():
    contract = load_contract()
    for notebook, nc in contract.notebooks.items():
        for rel, (kind, spec) in nc.files().items():
            path = ROOT / rel
            if kind in ("tables", "json", "markdown") and path.is_file():
                assert spec.undeclared(_columns(path)) == [], f"{notebook}: {rel}"


def test_an_unknown_section_is_an_error():
    with pytest.raises(ValueError, match="unknown section"):
        Contract.parse('["nb".charts.x]\nexact = ["a"]\n')


def test_floored_quantities_are_the_same_below_the_floor():
    from compendium.plotting import floored

    a, b = floored([1e-15, 3e-12, -2e-16], 1e-12), floored([3e-16, 3e-12, 5e-13], 1e-12)
    assert np.array_equal(a, b) and a.min() == 1e-12
    assert Error(floor=1e-12).accepts(pd.Series([1e-15]), pd.Series([8e-13])).all()
