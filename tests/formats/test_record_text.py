"""The cells and tokens of ``formats.record_text`` are ``serialize``'s, value by value: floats
of every magnitude and sign (the fixed-point fast path of ``csv_floats`` and its fallback,
their boundaries, ties of the ninth decimal), NaN and infinities, strings that need quoting
or escaping."""

from __future__ import annotations

import csv
import io
import json

import numpy as np

from aion_cli.formats import record_text as rt

EDGES = [
    0.0, -0.0, 4e-10, np.nextafter(4e-10, 0), 5e-10, -5e-10, 1e-9, 1e-4, np.nextafter(1e-4, 0),
    np.nextafter(1e-4, 1), 1e5, np.nextafter(1e5, 0), 99999.9999999999, 99999.99999999995,
    1 / 1024, -1 / 1024, 0.5, 1.0, 3.0, 1e16, 1e-320, 1.7976931348623157e308,
]


def _floats() -> np.ndarray:
    rng = np.random.default_rng(0)
    size = 10.0 ** rng.uniform(-13, 21, 200_000) * rng.choice([-1.0, 1.0], 200_000)
    return np.concatenate([size, rng.random(50_000), EDGES, [np.nan, np.inf, -np.inf]])


def test_csv_floats_are_repr_of_round_9() -> None:
    values = _floats()
    want = [repr(round(x, 9) + 0.0) if np.isfinite(x) else "" for x in values.tolist()]
    assert rt.csv_floats(values).tolist() == want
    assert rt.csv_floats(values.reshape(-1, 1)).shape == (values.size, 1)


def test_a_value_that_rounds_to_zero_is_never_a_negative_zero() -> None:
    """A direction of -6e-16 degrees (a circular mean of a symmetric histogram) was the cell
    -0.0 in predict's and export's CSV; it reads 0.0, by both writers, and a value that
    does not round to zero keeps its sign."""
    from aion_cli.formats.serialize import to_csv

    values = [-0.0, -5.887368655515379e-16, -4e-10, -4.9e-10, -6e-10, -1e-4]
    want = ["0.0", "0.0", "0.0", "0.0", "-1e-09", "-0.0001"]
    assert rt.csv_floats(values).tolist() == want
    rows = [{"v": v} for v in values]
    assert to_csv(rows, ["v"]).split("\n")[1:-1] == want


def test_json_floats_are_json_dumps() -> None:
    values = _floats()
    want = [json.dumps(x) if np.isfinite(x) else "null" for x in values.tolist()]
    assert rt.json_floats(values).tolist() == want


def test_strings() -> None:
    texts = ['a,b', 'say "hi"', "line\nbreak", "cr\r", "", "küche ☕", "\x1b[31m", "plain",
             None]
    cells = rt.csv_strings(np.array(texts, dtype=object)).tolist()
    for text, cell in zip(texts, cells, strict=True):
        buf = io.StringIO()
        csv.writer(buf, lineterminator="\n").writerow([text, "x"])
        assert cell + ",x\n" == buf.getvalue()
    tokens = rt.json_strings(np.array(texts, dtype=object)).tolist()
    assert tokens == [json.dumps(t) for t in texts]
