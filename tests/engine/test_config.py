"""ModelConfig: defaults, validation, TOML round trip."""

from __future__ import annotations

import pytest

from aion_cli.engine.config import ModelConfig, default_periods
from aion_cli.errors import ConfigError


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
     ("direction_floor", 0.5), ("periods", []),
     # each built a map that could not be scored, predicted or planned with
     ("direction_time_prior", 0.0), ("rate_floor", 1e300), ("rate_floor", 2.0),
     ("plan_speed", 1e-300), ("plan_speed", 21.0), ("pool_size", 1e-300)],
)
def test_invalid_values_are_rejected(key: str, value: object) -> None:
    with pytest.raises(ConfigError):
        ModelConfig.from_dict({key: value})


def test_a_parameter_above_the_model_table_is_an_error_not_ignored() -> None:
    """``cell_size = 1.0`` written at the top of a ``--print-config`` file, above its
    ``[model]`` header: TOML puts it outside the table, and the file was read from the table
    alone, so the build ran with cell_size 0.5 without a word. Now it is an error naming it;
    the same line under the header is read, as is a file without a table; another table
    beside [model] is refused as well (it was ignored too)."""
    text = ModelConfig().to_toml()
    with pytest.raises(ConfigError) as err:
        ModelConfig.from_toml_text("cell_size = 1.0\n" + text)
    assert "outside the [model] table" in str(err.value)
    assert "cell_size" in str(err.value)
    assert err.value.hint is not None
    assert "under [model]" in err.value.hint
    under = text.replace("[model]\n", "[model]\nbins = 12\n").replace("bins = 8\n", "")
    assert ModelConfig.from_toml_text(under).bins == 12
    assert ModelConfig.from_toml_text("cell_size = 1.0\n").cell_size == 1.0
    with pytest.raises(ConfigError, match=r"outside the \[model\] table.*: plan"):
        ModelConfig.from_toml_text(text + "[plan]\nplan_speed = 2.0\n")  # another table


def test_invalid_toml_is_a_config_error() -> None:
    with pytest.raises(ConfigError):
        ModelConfig.from_toml_text("cell_size = = 3")


@pytest.mark.parametrize(
    ("changes", "fragment"),
    [
        ({"window_s": 1e-6}, "window_s must be at least 1 s"),  # hung the build
        ({"window_s": 0.5}, "window_s must be at least 1 s"),
        ({"cell_size": 1e-3}, "cell_size must be in 0.01..1000 m"),  # ±1 km packable
        ({"cell_size": 5000.0}, "cell_size must be in 0.01..1000 m"),
        ({"window_s": 1.0, "profile_bin_s": 1.0, "profile": "week"}, "bins, over 2,016"),
        ({"window_s": 7200.0, "profile_bin_s": 7200.0}, "periods must lie in 14400..31622400 s"),
        ({"periods": [86400.0] * 65}, "at most 64"),
        ({"periods": [400 * 86400.0]}, "two windows to a year"),
        ({"profile_bin_s": 300.0}, "profile_bin_s (300.0) must be at least window_s"),
        ({"bins": True}, "bins must be an integer"),
        ({"window_s": True}, "window_s must be a positive number"),
        ({"derive_min_detections": "3"}, "derive_min_detections must be an integer"),
        ({"max_order": 2.0}, "max_order must be an integer"),
    ],
)
def test_documented_ranges_are_enforced(changes: dict, fragment: str) -> None:
    with pytest.raises(ConfigError) as err:
        ModelConfig.from_dict(changes)
    assert fragment in err.value.message


def test_the_edges_of_the_ranges_are_accepted() -> None:
    edges = {"window_s": 1.0, "profile_bin_s": 300.0, "profile": "week", "cell_size": 0.01}
    cfg = ModelConfig.from_dict({**edges, "periods": [2.0, 366 * 86400.0]})
    assert cfg.window_s == 1.0
    assert ModelConfig(cell_size=1000.0, window_s=86400.0, profile_bin_s=86400.0,
                       periods=(172800.0,)).cell_size == 1000.0  # fmt: skip


def test_a_stored_config_is_checked_as_a_map_fault() -> None:
    from aion_cli.errors import MapCorruptError

    good = ModelConfig().to_dict()
    assert ModelConfig.from_stored(good) == ModelConfig()
    for bad in ({**good, "window_s": 1e-6}, {**good, "bins": "eight"}, "window_s", None):
        with pytest.raises(MapCorruptError, match="stored model configuration"):
            ModelConfig.from_stored(bad)
