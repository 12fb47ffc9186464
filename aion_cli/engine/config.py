"""Every model parameter in one place, with defaults, validation and TOML round trip.

``aion build --print-config`` dumps :meth:`ModelConfig.to_toml`; ``--config FILE`` reads it
back through :meth:`ModelConfig.from_toml_text`. The config a map was built with is stored in
the map's manifest so results can be reproduced.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass, field
from typing import Any

from aion_cli.engine.errors import ConfigError

DAY_S = 86400.0
WEEK_S = 7 * DAY_S


def default_periods() -> tuple[float, ...]:
    """24 h/k (k = 1..24) and 7 d/k (k = 1..8), de-duplicated, longest first (31 periods)."""
    periods = {round(DAY_S / k, 6) for k in range(1, 25)} | {
        round(WEEK_S / k, 6) for k in range(1, 9)
    }
    return tuple(sorted(periods, reverse=True))


@dataclass(frozen=True)
class ModelConfig:
    """Model parameters. Lengths in metres, times in seconds.

    Spatial hash: ``cell_size`` (δ). Direction bins: ``bins`` (B), the paper's convention.
    Ownership transfer: a cell binds to the nearest node within ``bind_radius`` (horizontal)
    and ``bind_vertical_tolerance`` once that node has been present and has not moved more
    than ``stable_move_tolerance`` for ``stability_s`` (τ) seconds of log time.
    Time: windows of ``window_s`` (Δ) aligned to the UNIX epoch; the robot observes entries
    within ``sensor_range`` of its trajectory.
    Activity: a window with n detections has activity ``1 - exp(-n / activity_scale)``.
    FreMEn: ``periods``, a period counts once the row's observed span >= ``span_factor`` * T;
    orders 0..``max_order`` chosen per row by prequential error, a higher order only when it
    beats the lower one by ``order_bias`` (mean absolute error); once a row has 64 observations
    the prequential errors score only every ``score_stride``-th of them, weighted by it (1 scores
    every observation), each predicted by the row's model frozen at the start of its rank epoch
    of ``rank_period_s`` (a day: the error of forecasting the day ahead); direction
    predictions are floored at ``direction_floor`` and renormalised.
    Planning: edge cost ``d * (1 + w_entropy*H + w_flow*F + w_direction*c_d)`` (see
    ``engine.planning``), flow normalised by ``plan_flow_scale`` detections per window, or, with
    ``plan_flow_auto``, by the map's own busy level (the 90th percentile of its places'
    observed flow), since detection counts depend on the tracker's rate and the robot's route.
    """

    cell_size: float = 0.5
    bins: int = 8
    bind_radius: float = 1.0
    bind_vertical_tolerance: float = 1.0
    stability_s: float = 30.0
    stable_move_tolerance: float = 0.25
    window_s: float = 600.0
    sensor_range: float = 8.0
    activity_scale: float = 5.0
    periods: tuple[float, ...] = field(default_factory=default_periods)
    span_factor: float = 1.5
    max_order: int = 4
    order_bias: float = 0.002
    score_stride: int = 8
    rank_period_s: float = 86_400.0
    direction_floor: float = 0.01
    plan_speed: float = 1.0
    plan_w_entropy: float = 0.5
    plan_w_flow: float = 1.0
    plan_w_direction: float = 2.0
    plan_flow_scale: float = 10.0
    plan_flow_auto: bool = True
    plan_connect_radius: float = 2.5
    derive_spacing: float = 1.5
    derive_min_detections: int = 3

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Raise :class:`ConfigError` naming the first invalid parameter."""
        positive = (
            "cell_size",
            "bind_radius",
            "window_s",
            "sensor_range",
            "activity_scale",
            "span_factor",
            "rank_period_s",
            "plan_speed",
            "plan_flow_scale",
            "plan_connect_radius",
            "derive_spacing",
        )
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ConfigError(f"{name} must be a positive number, got {value!r}")
        non_negative = (
            "bind_vertical_tolerance",
            "stability_s",
            "stable_move_tolerance",
            "order_bias",
            "plan_w_entropy",
            "plan_w_flow",
            "plan_w_direction",
        )
        for name in non_negative:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ConfigError(f"{name} must be a number >= 0, got {value!r}")
        if not (isinstance(self.bins, int) and 2 <= self.bins <= 64):
            raise ConfigError(f"bins must be an integer in 2..64, got {self.bins!r}")
        if not (isinstance(self.max_order, int) and 0 <= self.max_order <= 16):
            raise ConfigError(f"max_order must be an integer in 0..16, got {self.max_order!r}")
        stride = self.score_stride
        if not (isinstance(stride, int) and not isinstance(stride, bool) and 1 <= stride <= 1024):
            raise ConfigError(f"score_stride must be an integer in 1..1024, got {stride!r}")
        if not (0 < self.direction_floor < 1.0 / self.bins):
            raise ConfigError(
                f"direction_floor must be in (0, 1/bins), got {self.direction_floor!r}"
            )
        if not self.periods or any(not (math.isfinite(p) and p > 0) for p in self.periods):
            raise ConfigError("periods must be a non-empty list of positive seconds")
        if not isinstance(self.plan_flow_auto, bool):
            raise ConfigError(f"plan_flow_auto must be true or false, got {self.plan_flow_auto!r}")
        if self.derive_min_detections < 1:
            raise ConfigError("derive_min_detections must be >= 1")

    # -- conversions -------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        data = dataclasses.asdict(self)
        data["periods"] = list(self.periods)
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ModelConfig:
        """Build from a (possibly partial) dict; unknown keys are an error listing valid ones."""
        valid = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - valid)
        if unknown:
            raise ConfigError(
                f"unknown model parameter(s): {', '.join(unknown)}",
                hint=f"valid parameters: {', '.join(sorted(valid))}"
                " (see `aion build --print-config`)",
            )
        kwargs = dict(data)
        if "periods" in kwargs:
            try:
                kwargs["periods"] = tuple(float(p) for p in kwargs["periods"])
            except (TypeError, ValueError) as exc:
                raise ConfigError(f"periods must be a list of numbers: {exc}") from exc
        for f in dataclasses.fields(cls):
            if f.name in kwargs and f.type in ("float", float):
                value = kwargs[f.name]
                if isinstance(value, int) and not isinstance(value, bool):
                    kwargs[f.name] = float(value)
        try:
            return cls(**kwargs)
        except TypeError as exc:
            raise ConfigError(f"invalid model parameters: {exc}") from exc

    def replace(self, **changes: Any) -> ModelConfig:
        return ModelConfig.from_dict({**self.to_dict(), **changes})

    @classmethod
    def from_toml_text(cls, text: str) -> ModelConfig:
        """Parse TOML; parameters may sit at top level or under a ``[model]`` table."""
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise ConfigError(f"invalid TOML: {exc}") from exc
        if "model" in data and isinstance(data["model"], dict):
            data = data["model"]
        return cls.from_dict(data)

    def to_toml(self) -> str:
        """TOML text with every parameter under ``[model]`` (re-readable by from_toml_text)."""
        lines = ["# aion model parameters (aion build --config FILE)", "[model]"]
        for key, value in self.to_dict().items():
            if isinstance(value, list):
                body = ", ".join(repr(float(v)) for v in value)
                lines.append(f"{key} = [{body}]")
            elif isinstance(value, bool):
                lines.append(f"{key} = {'true' if value else 'false'}")
            else:
                lines.append(f"{key} = {value!r}")
        return "\n".join(lines) + "\n"
