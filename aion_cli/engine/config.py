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
from datetime import timezone
from typing import Any

from aion_cli.errors import ConfigError

DAY_S = 86400.0
WEEK_S = 7 * DAY_S

# Documented ranges (README "Model parameters"; checked by ModelConfig.validate, also when a
# map's stored config is read). Each bound keeps a resource or a representation finite:
MIN_WINDOW_S = 1.0
"""Shortest window Δ: windows are closed one by one, and a map keeps per-window state."""
CELL_SIZE_RANGE = (0.01, 1000.0)
"""δ in metres: cell indices are packed into 21 bits per axis (±2^20 cells), so δ = 1 cm
already limits a map to ±10.5 km; above 1 km a cell is no longer a place."""
MAX_PROFILE_BINS = 2016
"""Most periodic-profile bins H (a week of 5-minute bins): every entry keeps H values per
direction bin."""
MAX_PERIODS = 64
"""Most FreMEn periods: every entry keeps one complex sum per period and direction bin."""
MAX_PERIOD_S = 366 * DAY_S
"""Longest FreMEn period (a year); the shortest is two windows (Nyquist: a shorter period
cannot be seen in per-window counts)."""
FAMILIES = ("static", "shape", "profile", "fremen")

RANGES_HINT = (
    "the README's 'The model and its parameters' gives every parameter's range; "
    "`aion build --print-config` prints the defaults"
)
"""The hint of a parameter out of its range that has no hint of its own."""
"""The temporal model families (``engine.temporal.params``)."""


def stored_config(data: dict[str, Any]) -> dict[str, Any]:
    """A map's stored model configuration with the keys older versions did not write, as
    those versions built: ``exposure`` false (their robot windows counted whole, and a map
    continued from one goes on so), ``fremen_clock`` ``"utc"`` in a zone with daylight saving
    (their FreMEn sums are on UTC). ``ModelConfig.from_stored`` and ``aion info`` / ``aion
    report`` (through :class:`~aion_cli.manifest.Manifest`) read it alike, so an old map is
    not shown as built with the defaults it does not use."""
    return {"exposure": False, **_old_clock(data), **data}


FREMEN_CLOCKS = ("standard", "utc")
"""``ModelConfig.fremen_clock``: the time FreMEn's phases follow."""


def _old_clock(data: dict[str, Any]) -> dict[str, Any]:
    """``fremen_clock = "utc"`` for a stored config without the key in a zone with daylight
    saving (FreMEn's phases were on UTC before the key existed); nothing in UTC or a fixed
    offset, where the clocks are one."""
    try:
        fixed = _fixed_zone(str(data.get("timezone", "UTC")))
    except ConfigError:
        return {}  # the zone is refused where the config is read
    return {} if fixed else {"fremen_clock": "utc"}


def _fixed_zone(name: str) -> bool:
    from aion_cli.engine.temporal.zones import zone_of

    return isinstance(zone_of(name), timezone)


def _is_number(value: object) -> bool:
    """An int or float, not a bool (``True`` is an int to Python, not a length to us)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _is_int(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def default_periods() -> tuple[float, ...]:
    """24 h/k (k = 1..24) and 7 d/k (k = 1..8), de-duplicated, longest first (31 periods)."""
    periods = {round(DAY_S / k, 6) for k in range(1, 25)} | {
        round(WEEK_S / k, 6) for k in range(1, 9)
    }
    return tuple(sorted(periods, reverse=True))


BOUNDED = {
    "rate_floor": (1e-12, 1.0),
    "plan_speed": (0.01, 20.0),
    "pool_size": (0.1, 1000.0),
}
"""Parameters with a range beyond being positive: outside it the map builds but cannot be
scored (a floor above one detection per window) or planned with (``aion plan --speed``'s
range), or pools nothing (a neighbourhood smaller than a hand)."""
BOUNDED_WHY = {
    "rate_floor": "the smallest rate a log-likelihood uses, in detections per window (1e-3)",
    "plan_speed": "walking speed in m/s, as aion plan --speed takes it",
    "pool_size": "metres: the neighbourhood a sparse entry borrows from (4)",
}


@dataclass(frozen=True)
class ModelConfig:
    """Model parameters. Lengths in metres, times in seconds.

    Spatial hash: ``cell_size`` (δ). Direction bins: ``bins`` (B), the paper's convention.
    Ownership transfer: a cell binds to the nearest node within ``bind_radius`` (horizontal)
    and ``bind_vertical_tolerance`` once that node has been present and has not moved more
    than ``stable_move_tolerance`` for ``stability_s`` (τ) seconds of log time.
    Time: windows of ``window_s`` (Δ) aligned to the UNIX epoch; the robot observes entries
    within ``sensor_range`` of its trajectory, and with ``exposure`` a window it observed an
    entry in counts by the fraction of the window the entry was in range, at least
    ``exposure_floor``, and a fixed sensor's window by the share of it its logs recorded
    (``engine.observation``; without, every such window counts whole, as in
    the paper).
    Temporal model (``engine.temporal``): the expected detections per observed window of every
    entry and direction bin, forecast by the families in ``families`` (``static``, ``shape``,
    ``profile``, ``fremen``; static is always on) and chosen per entry by day-ahead score, a
    more complex family only when it beats the simpler one by ``family_margin`` nats; with
    ``reconcile`` the entries' total follows the map's pooled profile. Days and
    the periodic ``profile`` (``day``, ``day_weekend`` or ``week`` with bins of
    ``profile_bin_s``) follow the local clock of ``timezone``; a ``week`` map forecasts with
    its bins pooled into weekdays and weekends unless its week sums ask for the week
    (``temporal.calendar_view``). An entry's profile is shrunk
    toward its borrowed shape with ``profile_prior`` pseudo-detections per bin; the map's and
    the groups' shapes by a strength estimated from the map itself (how bursty its window
    counts are and how much its bins vary beyond that: ``temporal.shape_prior``).
    FreMEn: ``periods``, a period counts once an entry's observed span >= ``span_factor`` * T,
    orders 1..``max_order``, phases on ``fremen_clock``: ``"standard"``, UTC plus the zone's
    daylight-saving shift (the local clock less the standard offset, so a routine keeps its
    phase across a clock change), or ``"utc"``, as maps built before it (a stored config
    without the key; in a zone without daylight saving the two are one clock, recorded as
    the default and not written). Directions: a Dirichlet prior of ``direction_prior``
    pseudo-detections (``"auto"``: estimated from the map, ``temporal.direction_prior``)
    toward the parent's histogram (room, else the ``pool_size``-metre
    neighbourhood; then the map), time-varying histograms shrunk toward the entry's static
    one, modulated by its group's hour (``temporal.group_shift``), with
    ``direction_time_prior`` pseudo-detections (``"auto"``: estimated from the map's profile
    bins, ``temporal.direction_prior.time_prior``). Log-likelihoods floor
    rates at ``rate_floor`` detections per window.
    Planning: edge cost ``d * (1 + (w_entropy*H + w_flow)*F + w_direction*c_d)`` (see
    ``engine.planning``: entropy counts as busy as the place is), flow normalised by
    ``plan_flow_scale`` detections per window, or, with
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
    exposure: bool = True
    exposure_floor: float = 0.2
    timezone: str = "UTC"
    families: tuple[str, ...] = FAMILIES
    profile: str = "day_weekend"
    profile_bin_s: float = 3600.0
    profile_prior: float = 5.0
    family_margin: float = 3.0
    reconcile: bool = True
    periods: tuple[float, ...] = field(default_factory=default_periods)
    span_factor: float = 1.5
    max_order: int = 4
    fremen_clock: str = "standard"
    direction_prior: float | str = "auto"
    direction_time_prior: float | str = "auto"
    pool_size: float = 4.0
    rate_floor: float = 1e-3
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
        if isinstance(self.families, list):
            object.__setattr__(self, "families", tuple(self.families))
        if isinstance(self.periods, list):
            object.__setattr__(self, "periods", tuple(float(p) for p in self.periods))
        self.validate()

    def validate(self) -> None:
        """Raise :class:`ConfigError` naming the first invalid parameter."""
        positive = (
            "cell_size",
            "bind_radius",
            "window_s",
            "sensor_range",
            "span_factor",
            "profile_bin_s",
            "pool_size",
            "rate_floor",
            "plan_speed",
            "plan_flow_scale",
            "plan_connect_radius",
            "derive_spacing",
        )
        for name in positive:
            value = getattr(self, name)
            if not (_is_number(value) and math.isfinite(value) and value > 0):
                raise ConfigError(f"{name} must be a positive number, got {value!r}")
        non_negative = (
            "bind_vertical_tolerance",
            "stability_s",
            "stable_move_tolerance",
            "profile_prior",
            "family_margin",
            "plan_w_entropy",
            "plan_w_flow",
            "plan_w_direction",
        )
        for name in non_negative:
            value = getattr(self, name)
            if not (_is_number(value) and math.isfinite(value) and value >= 0):
                raise ConfigError(f"{name} must be a number >= 0, got {value!r}")
        prior = self.direction_prior
        if isinstance(prior, str):
            if prior != "auto":
                raise ConfigError(
                    f'direction_prior must be a number >= 0 or "auto", got {prior!r}',
                    hint='"auto" estimates it from the map (the default); 0 keeps the raw '
                    "proportions",
                )
        elif not (_is_number(prior) and math.isfinite(prior) and prior >= 0):
            raise ConfigError(f'direction_prior must be a number >= 0 or "auto", got {prior!r}')
        time_prior = self.direction_time_prior
        auto = isinstance(time_prior, str) and time_prior == "auto"
        if not auto and not (
            not isinstance(time_prior, str)
            and _is_number(time_prior)
            and math.isfinite(time_prior)
            and time_prior > 0
        ):
            raise ConfigError(
                f'direction_time_prior must be a positive number or "auto", got {time_prior!r}',
                hint='"auto" estimates it from the map (the default)',
            )
        for name, (lo, hi) in BOUNDED.items():
            value = getattr(self, name)
            if not lo <= value <= hi:
                raise ConfigError(
                    f"{name} must be {lo:g} .. {hi:g}, got {value!r}", hint=BOUNDED_WHY[name]
                )
        if not (_is_int(self.bins) and 2 <= self.bins <= 64):
            raise ConfigError(
                f"bins must be an integer in 2..64, got {self.bins!r}",
                hint="the direction bins of a full turn: 8 (45 degrees each) is the default",
            )
        if not (_is_int(self.max_order) and 0 <= self.max_order <= 16):
            raise ConfigError(f"max_order must be an integer in 0..16, got {self.max_order!r}")
        lo, hi = CELL_SIZE_RANGE
        if not lo <= self.cell_size <= hi:
            raise ConfigError(
                f"cell_size must be in {lo:g}..{hi:g} m, got {self.cell_size!r}",
                hint="cell indices are packed into 21 bits per axis: a cell of 1 cm already "
                "limits the map to ±10.5 km",
            )
        unknown = [f for f in self.families if f not in FAMILIES]
        if unknown or not self.families or len(set(self.families)) != len(self.families):
            raise ConfigError(
                f"families must be distinct names from {', '.join(FAMILIES)}, got "
                f"{list(self.families)!r}"
            )
        if self.window_s > DAY_S:
            raise ConfigError(f"window_s must be at most a day (86400), got {self.window_s!r}")
        if self.window_s < MIN_WINDOW_S:
            raise ConfigError(
                f"window_s must be at least {MIN_WINDOW_S:g} s, got {self.window_s!r}",
                hint="windows are closed one by one: the default is 600 s",
            )
        if self.profile_bin_s < self.window_s:
            raise ConfigError(
                f"profile_bin_s ({self.profile_bin_s!r}) must be at least window_s "
                f"({self.window_s!r}): a window enters the profile at its centre time",
            )
        if self.fremen_clock not in FREMEN_CLOCKS:
            raise ConfigError(
                f'fremen_clock must be "standard" or "utc", got {self.fremen_clock!r}',
                hint='"standard" (the default) keeps a routine\'s phase across a daylight-saving '
                'change; "utc" is the clock of maps built before it',
            )
        self._validate_calendar()
        self._validate_periods()
        if not isinstance(self.exposure, bool):
            raise ConfigError(f"exposure must be true or false, got {self.exposure!r}")
        floor = self.exposure_floor
        if not (_is_number(floor) and math.isfinite(floor) and 0.0 < floor <= 1.0):
            raise ConfigError(
                f"exposure_floor must be in (0, 1], got {floor!r}",
                hint="the least share of a window a robot's look counts for: 0.2 by default, "
                "1 counts every look as a whole window",
            )
        if not isinstance(self.reconcile, bool):
            raise ConfigError(f"reconcile must be true or false, got {self.reconcile!r}")
        if not isinstance(self.plan_flow_auto, bool):
            raise ConfigError(f"plan_flow_auto must be true or false, got {self.plan_flow_auto!r}")
        if not (_is_int(self.derive_min_detections) and self.derive_min_detections >= 1):
            raise ConfigError(
                f"derive_min_detections must be an integer >= 1, got "
                f"{self.derive_min_detections!r}"
            )

    def _validate_periods(self) -> None:
        periods = self.periods
        if not periods or any(not (_is_number(p) and math.isfinite(p) and p > 0) for p in periods):
            raise ConfigError("periods must be a non-empty list of positive seconds")
        if len(periods) > MAX_PERIODS:
            raise ConfigError(f"periods: at most {MAX_PERIODS}, got {len(periods)}")
        shortest = 2.0 * self.window_s
        bad = [p for p in periods if not shortest <= p <= MAX_PERIOD_S]
        if bad:
            raise ConfigError(
                f"periods must lie in {shortest:g}..{MAX_PERIOD_S:.0f} s (two windows to a year), "
                f"got {bad[0]!r}",
                hint="a period shorter than two windows cannot be seen in per-window counts: "
                "drop it from periods or use a shorter window_s",
            )

    def _validate_calendar(self) -> None:
        from aion_cli.engine.temporal.calendar import Calendar
        from aion_cli.engine.temporal.zones import zone_key

        for name in ("timezone", "profile"):
            if not isinstance(getattr(self, name), str):
                raise ConfigError(f"{name} must be a string, got {getattr(self, name)!r}")
        calendar = Calendar(self.timezone, self.profile, self.profile_bin_s)  # ConfigError
        # one spelling per zone ("+05:30" is UTC+05:30, as --tz writes it), so two maps or a
        # map and --tz that name one zone agree
        object.__setattr__(self, "timezone", zone_key(self.timezone))
        if calendar.fixed:  # no daylight saving: FreMEn's clocks are one, named by the default
            object.__setattr__(self, "fremen_clock", "standard")
        if calendar.n_bins > MAX_PROFILE_BINS:
            raise ConfigError(
                f"the {self.profile} profile with profile_bin_s = {self.profile_bin_s!r} has "
                f"{calendar.n_bins:,} bins, over {MAX_PROFILE_BINS:,}",
                hint="use longer profile bins (3600 s by default)",
            )

    # -- conversions -------------------------------------------------------------------------
    @classmethod
    def from_stored(cls, data: object) -> ModelConfig:
        """The config a map stored (its manifest's ``state.config``), validated like a config
        file; any fault is a :class:`~aion_cli.errors.MapCorruptError` naming it (a map
        with a 1e-6 s window or a 10^6-bin profile never reaches the engine)."""
        from aion_cli.errors import MAP_REBUILD_HINT, MapCorruptError

        if not isinstance(data, dict):
            raise MapCorruptError(
                f"the map's stored model configuration is not an object: {data!r:.80}",
                hint=MAP_REBUILD_HINT,
            )
        try:
            return cls.from_dict(stored_config(data))
        except ConfigError as exc:
            raise MapCorruptError(
                f"the map's stored model configuration is invalid: {exc.message}",
                hint=MAP_REBUILD_HINT,
            ) from exc

    def to_dict(self) -> dict[str, Any]:
        """Every parameter, as a map stores it: ``fremen_clock`` is left out in UTC and fixed
        offsets, where its clocks are one (such maps stay as those built before the key)."""
        data = self.parameters()
        if self.fremen_clock == "standard" and _fixed_zone(self.timezone):
            del data["fremen_clock"]
        return data

    def parameters(self) -> dict[str, Any]:
        """Every parameter, ``fremen_clock`` too (what ``--print-config`` prints)."""
        data = dataclasses.asdict(self)
        data["periods"] = list(self.periods)
        data["families"] = list(self.families)
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
                raise ConfigError(
                    f"periods must be a list of numbers: {exc}", hint=RANGES_HINT
                ) from exc
        if "families" in kwargs:
            families = kwargs["families"]
            if isinstance(families, str) or not isinstance(families, (list, tuple)):
                raise ConfigError(
                    f"families must be a list of names, got {families!r}",
                    hint=f"e.g. families = {list(FAMILIES)!r}".replace("'", '"'),
                )
            kwargs["families"] = tuple(str(f) for f in families)
        for f in dataclasses.fields(cls):
            if f.name in kwargs and f.type in ("float", float, "float | str"):
                value = kwargs[f.name]
                if isinstance(value, int) and not isinstance(value, bool):
                    kwargs[f.name] = float(value)
        try:
            return cls(**kwargs)
        except (TypeError, ValueError, OverflowError) as exc:  # e.g. a string compared to 0
            raise ConfigError(f"invalid model parameters: {exc}", hint=RANGES_HINT) from exc
        except ConfigError as exc:  # a value out of its range: where the ranges are
            if exc.hint is not None:
                raise
            raise ConfigError(exc.message, hint=RANGES_HINT) from exc

    def replace(self, **changes: Any) -> ModelConfig:
        return ModelConfig.from_dict({**self.to_dict(), **changes})

    @classmethod
    def from_toml_text(cls, text: str) -> ModelConfig:
        """Parse TOML; parameters may sit at top level or under a ``[model]`` table."""
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise ConfigError(
                f"invalid TOML: {exc}",
                hint="aion build --print-config > model.toml writes a valid file to edit",
            ) from exc
        if "model" in data and isinstance(data["model"], dict):
            outside = sorted(k for k in data if k != "model")
            if outside:  # above its header, or other tables: they would be left out unsaid
                raise ConfigError(
                    f"parameter(s) outside the [model] table, which would be ignored: "
                    f"{', '.join(outside)} (a file with a [model] table is read from it alone)",
                    hint="move them under [model] (after its header line)",
                )
            data = data["model"]
        return cls.from_dict(data)

    def to_toml(self) -> str:
        """TOML text with every parameter under ``[model]`` (re-readable by from_toml_text)."""
        lines = ["# aion model parameters (aion build --config FILE)", "[model]"]
        for key, value in self.parameters().items():
            if isinstance(value, list):
                body = ", ".join(f'"{v}"' if isinstance(v, str) else repr(float(v)) for v in value)
                lines.append(f"{key} = [{body}]")
            elif isinstance(value, str):
                lines.append(f'{key} = "{value}"')
            elif isinstance(value, bool):
                lines.append(f"{key} = {'true' if value else 'false'}")
            else:
                lines.append(f"{key} = {value!r}")
        return "\n".join(lines) + "\n"
