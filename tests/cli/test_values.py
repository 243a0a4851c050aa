"""The command line's values (flexbody.cli.values): ``--set`` literals, and the lists of ``--refine``,
``--grid`` and ``--sweep``."""

from __future__ import annotations

import pytest

from flexbody.cli.errors import CliError
from flexbody.cli.values import (parse_grid, parse_load_factor, parse_refine, parse_sets, parse_sweep, parse_value,
                                 value_list)


@pytest.mark.parametrize("text, value", [("4", 4), ("1e-3", 1e-3), ("True", True), ("false", False),
                                         ("[1, 2]", [1, 2]), ("mitc7", "mitc7"), ("'quoted'", "quoted"),
                                         ("1 +", "1 +")])
def test_a_set_value_is_a_literal_else_the_text(text, value):
    got = parse_value(text)
    assert got == value and type(got) is type(value)


def test_sets_strip_keys_and_values_and_a_later_key_wins():
    assert parse_sets([" nx = 4", "thickness=0.1", "nx=8", "kernel=mitc7"]) == {"nx": 8, "thickness": 0.1,
                                                                               "kernel": "mitc7"}
    assert parse_sets(["expr=a=b"]) == {"expr": "a=b"}


@pytest.mark.parametrize("item", ["nx", "=4", " =4"])
def test_a_set_without_a_key_is_refused(item):
    with pytest.raises(CliError, match=f"--set expects KEY=VALUE, got {item!r}"):
        parse_sets([item])


def test_a_value_list_leaves_out_empty_items():
    assert value_list("4, 8,,16,") == [4, 8, 16]
    assert value_list(" , ") == []


def test_refine_pairs_its_lists_by_position():
    assert parse_refine(["nx=4,8,16", "ny=1,2,4"]) == [{"nx": 4, "ny": 1}, {"nx": 8, "ny": 2}, {"nx": 16, "ny": 4}]
    assert parse_refine([]) == []
    with pytest.raises(CliError, match="--refine lists must have the same length, got nx: 2, ny: 1"):
        parse_refine(["nx=1,2", "ny=1"])
    with pytest.raises(CliError, match="--refine nx has no values"):
        parse_refine(["nx=,"])
    with pytest.raises(CliError, match="--refine expects KEY=V1,V2,..., got 'nx'"):
        parse_refine(["nx"])


def test_grid_keeps_its_keys_in_order_and_refuses_a_key_twice():
    assert parse_grid(["nx=2,4", "thickness=0.01,0.02"]) == {"nx": [2, 4], "thickness": [0.01, 0.02]}
    assert list(parse_grid(["b=1", "a=2"])) == ["b", "a"]
    with pytest.raises(CliError, match="--grid nx is given twice"):
        parse_grid(["nx=2", "nx=3"])
    with pytest.raises(CliError, match="--grid nx has no values"):
        parse_grid(["nx="])
    for item in ("nx", "=2,4"):
        with pytest.raises(CliError, match="--grid expects KEY=V1,V2"):
            parse_grid([item])


def test_sweep_takes_one_key_and_spin_rates_that_are_finite_and_not_negative():
    assert parse_sweep("omega=0, 5,10.5") == ("omega", [0, 5, 10.5])
    assert parse_sweep("thickness=0.1,0.2") == ("thickness", [0.1, 0.2])
    for text in ("omega", "=1,2", "omega="):
        with pytest.raises(CliError, match="--sweep expects KEY=V1,V2"):
            parse_sweep(text)
    for bad in ("-1", "inf", "true", "fast"):
        with pytest.raises(CliError, match="--sweep omega values must be finite numbers >= 0"):
            parse_sweep(f"omega=1,{bad}")


def test_load_factor_is_a_finite_number_or_end():
    assert parse_load_factor(None) is None and parse_load_factor("end") == "end"
    assert parse_load_factor("0.5") == 0.5
    with pytest.raises(CliError, match="--load-factor must be a number or 'end', got 'abc'"):
        parse_load_factor("abc")
    with pytest.raises(CliError, match="--load-factor must be finite, got 'nan'"):
        parse_load_factor("nan")
