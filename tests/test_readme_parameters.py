"""README's "The model and its parameters" against the code: every parameter `aion build
--print-config` prints is in the table exactly once, with the default the code has."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path
from typing import Any

from aion_cli.engine.config import ModelConfig, default_periods

README = Path(__file__).resolve().parents[1] / "README.md"


def _table() -> dict[str, str]:
    """Parameter -> its default as the table gives it (units stripped later)."""
    text = README.read_text()
    section = text.split("## The model and its parameters", 1)[1].split("\n## ", 1)[0]
    rows = re.findall(r"^\| (`[^|]+`) \| ([^|]+) \|", section, re.M)
    out: dict[str, str] = {}
    for names_cell, default_cell in rows:
        names = re.findall(r"`(\w+)`", names_cell)
        defaults = [default_cell.strip()] if len(names) == 1 else default_cell.split(", ")
        assert len(defaults) == len(names), (names_cell, default_cell)
        for name, default in zip(names, defaults, strict=True):
            assert name not in out, f"{name} is in README's parameter table twice"
            out[name] = default.strip()
    return out


def _value(text: str) -> Any:
    """A table cell's default as a value: a number without its unit, true / false, a name."""
    if text in ("true", "false"):
        return text == "true"
    number = re.fullmatch(r"([-+0-9.e]+)( ?(m|s|m/s|nats))?", text)
    if number:
        return float(number.group(1))
    return text


def test_every_printed_parameter_is_in_the_readme_table_with_its_default() -> None:
    printed = tomllib.loads(ModelConfig().to_toml())["model"]
    table = _table()
    assert set(table) == set(printed), (
        f"missing from README: {sorted(set(printed) - set(table))}; "
        f"not a parameter: {sorted(set(table) - set(printed))}"
    )
    for name, default in printed.items():
        cell = table[name]
        if name == "periods":  # 24 h/k (k <= 24) and 7 d/k (k <= 8): 31 distinct periods
            assert default == list(default_periods())
            assert cell == "24 h/k (k ≤ 24), 7 d/k (k ≤ 8)", cell
            assert f"FreMEn candidate periods ({len(default)})" in README.read_text()
        elif name == "families":
            assert cell == ", ".join(default), (name, cell, default)
        elif isinstance(default, bool):
            assert _value(cell) is default, (name, cell, default)
        elif isinstance(default, (int, float)):
            assert _value(cell) == float(default), (name, cell, default)
        else:
            assert _value(cell) == default, (name, cell, default)
