"""The one node-id formatter agrees with spark_dsg's own NodeSymbol, and parsing inverts it."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from aion_cli.engine.node_ids import INDEX_MASK, node_label, parse_node_id, parse_point
from aion_cli.errors import InputError


@given(
    category=st.sampled_from("pPoOrRbBaAxXlL"),
    index=st.integers(min_value=0, max_value=INDEX_MASK),
)
def test_label_is_spark_dsg_short_form_and_parses_back(category: str, index: int) -> None:
    import spark_dsg

    symbol = spark_dsg.NodeSymbol(category, index)
    value = int(symbol.value)
    assert node_label(value) == symbol.str()  # "p12"
    assert parse_node_id(symbol.str()) == value
    assert parse_node_id(str(symbol)) == value  # the long form "p(12)"
    assert parse_node_id(str(value)) == value  # a raw integer id


def test_ids_without_a_printable_category_stay_numeric() -> None:
    assert node_label(12) == "12"
    assert node_label((200 << 56) | 3) == str((200 << 56) | 3)


@pytest.mark.parametrize(
    "text",
    # "²" is a digit to str.isdigit, not to int(); 2**64 does not fit a uint64 node id
    # "p٣": an Arabic-Indic three is a digit to the regex module's Unicode \d, not an id
    ["", "p", "12p", "p-1", "pp12", "p(12", "²", "18446744073709551616", "9" * 30, "p٣"],
)
def test_bad_ids_are_input_errors(text: str) -> None:
    with pytest.raises(InputError):
        parse_node_id(text)


def test_points() -> None:
    x, y, z = parse_point("3.5,-1") or (0.0, 0.0, 0.0)
    assert (x, y) == (3.5, -1.0)
    assert math.isnan(z)  # no height given: distances from it are horizontal
    assert parse_point("1,2,3") == (1.0, 2.0, 3.0)
    assert parse_point("p12") is None
    with pytest.raises(InputError):
        parse_point("nan,1")


@given(st.lists(st.integers(min_value=0, max_value=2**64 - 1), max_size=50))
def test_the_array_form_equals_the_scalar_form(values: list[int]) -> None:
    import numpy as np

    from aion_cli.engine.node_ids import node_labels

    ids = np.asarray(values, dtype=np.uint64)
    assert node_labels(ids).tolist() == [node_label(v) for v in values]


def test_a_far_point_is_refused_naming_the_limit_applied() -> None:
    """A point is taken within 10 m of an entry, or within the map's span where that is more.
    A map of one entry spans 0 m: a point 5 m from it stands for it, one 27 m away is refused,
    and the error says 10 m was the limit (it had said "farther than the whole map spans
    (0 m)", which the 5 m point is too). A map 45 m across names its span."""
    from aion_cli.engine.node_ids import refuse_far_point

    one = [[0.0, 0.0, 0.0]]
    refuse_far_point("3,4", 5.0, "c1", one, "entry")  # within 10 m: no error
    with pytest.raises(InputError) as caught:
        refuse_far_point("20,20", math.hypot(20, 20), "c1", one, "entry")
    assert caught.value.message == (
        "the point 20,20 is 28 m from the nearest entry (c1), farther than 10 m, more than "
        "the whole map spans (0 m): coordinates in another frame or unit?"
    )
    wide = [[0.0, 0.0, 0.0], [27.0, 36.0, 0.0]]  # 45 m across
    refuse_far_point("60,0", 33.0, "p1", wide)  # within the span: no error
    with pytest.raises(InputError) as caught:
        refuse_far_point("1000,1000", 1375.0, "p1", wide)
    assert caught.value.message == (
        "the point 1000,1000 is 1,375 m from the nearest place (p1), farther than the whole "
        "map spans (45 m): coordinates in another frame or unit?"
    )
