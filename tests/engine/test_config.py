"""ModelConfig: defaults, validation, TOML round trip."""

from __future__ import annotations

import pytest

from aion_cli.engine.config import ModelConfig, default_periods
from aion_cli.engine.errors import ConfigError


def test_default_periods_are_31_daily_and_weekly_harmonics() -> None:
    periods = default_periods()
    assert len(periods) == 31
    assert periods[0] == 604800.0
    assert 86400.0 in periods
    assert 3600.0 in periods
    assert len(set(periods)) == len(periods)


def test_toml_round_trip_preserves_every_parameter() -> None:
    cfg = ModelConfig().replace(cell_size=0.3, bins=12, periods=[86400.0, 3600.0])
    again = ModelConfig.from_toml_text(cfg.to_toml())
    assert again == cfg


def test_unknown_parameter_lists_valid_ones() -> None:
    with pytest.raises(ConfigError) as err:
        ModelConfig.from_dict({"cel_size": 1.0})
    assert "cel_size" in str(err.value)
    assert err.value.hint is not None
    assert "cell_size" in err.value.hint


@pytest.mark.parametrize(
    ("key", "value"),
    [("cell_size", 0.0), ("cell_size", float("nan")), ("bins", 1), ("window_s", -5.0),
     ("direction_floor", 0.5), ("periods", [])],
)
def test_invalid_values_are_rejected(key: str, value: object) -> None:
    with pytest.raises(ConfigError):
        ModelConfig.from_dict({key: value})


def test_invalid_toml_is_a_config_error() -> None:
    with pytest.raises(ConfigError):
        ModelConfig.from_toml_text("cell_size = = 3")
