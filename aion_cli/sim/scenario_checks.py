"""The checks of a simulation's options (:meth:`ScenarioConfig.validate`): every impossible
combination refused with an :class:`~aion_cli.errors.InputError` before any work is done."""

from __future__ import annotations

import math

from aion_cli.errors import InputError
from aion_cli.formats.tf import MAX_GAP_S
from aion_cli.sim.graphstream import StreamConfig
from aion_cli.sim.messages import detection_msgtype
from aion_cli.sim.scenario import (
    FORMATS,
    LAST_START_NS,
    MAX_AGENTS,
    MAX_SCENES,
    MAX_TICKS,
    MIN_PERIOD_S,
    ScenarioConfig,
    start_ns,
)


def validate_scenario(config: ScenarioConfig) -> None:
    """Raise :class:`InputError` for impossible combinations of ``config``'s options."""
    finite = (
        config.days, config.utc_offset_h, config.rate_hz, config.noise, config.window_s,
        config.tf_idle_s, config.stream.period_s, config.stream.idle_period_s,
        config.patrol.tour_every_s, config.patrol.sensor_range,
    )  # fmt: skip
    if not all(math.isfinite(v) for v in finite):
        raise InputError(
            "simulate's numbers must be finite (no nan or inf)",
            hint="give --days and the other numbers as plain values, e.g. --days 2.5",
        )
    periods = (
        config.tf_idle_s, config.stream.period_s, config.stream.idle_period_s,
        config.patrol.tour_every_s,
    )  # fmt: skip
    checks = [
        (config.days > 0, "--days must be positive"),
        (0 <= config.seed < 2**63, f"--seed must be a whole number 0 .. {2**63 - 1}"),
        (0 <= config.agents <= MAX_AGENTS, f"--agents must be 0 .. {MAX_AGENTS}"),
        (1 <= config.scenes <= MAX_SCENES, f"--scenes must be 1 .. {MAX_SCENES}"),
        (0.01 <= config.rate_hz <= 100.0, "--rate must be 0.01 .. 100 Hz"),
        (0 <= config.noise <= 10.0, "--noise must be 0 .. 10 m"),
        (-14.0 <= config.utc_offset_h <= 14.0, "--utc-offset must be -14 .. 14 hours"),
        (
            min(periods) >= MIN_PERIOD_S and max(periods) <= (config.days + 1) * 86400.0,
            f"scene-graph, TF and patrol periods must be {MIN_PERIOD_S:g} s .. the "
            "simulated days",
        ),
        (60.0 <= config.window_s <= 86400.0, "--window must be 60 .. 86400 s"),
        (config.robot in ("patrol", "fixed"), "--robot must be patrol or fixed"),
        (config.resolved_frame() in ("base_link", "map"), "--frame must be base_link or map"),
        (config.format in FORMATS, f"--format must be one of {', '.join(FORMATS)}"),
        (config.bins >= 1, "bins must be positive"),
        (
            config.stream.period_s > 0 and config.stream.idle_period_s > 0,
            "scene-graph periods must be positive",
        ),
        (config.patrol.tour_every_s > 0, "the patrol interval must be positive"),
        (config.tf_idle_s > 0, "the TF period must be positive"),
        (
            config.tf_idle_s <= 0 or config.robot == "fixed" or config._tf_gap_s() <= MAX_GAP_S,
            f"a parked robot's TF would come every {config._tf_gap_s():g} s (--tf-idle-period "
            f"in ticks of --rate): aion build takes a gap over {MAX_GAP_S:g} s between TF "
            "samples as time the robot's pose was unknown (tf2's cache length), so the "
            "parked robot would observe nothing: give a shorter --tf-idle-period or a "
            "higher --rate",
        ),
        (config.patrol.sensor_range > 0, "the sensor range must be positive"),
        (
            bool(config.environment.strip()),
            "--environment is empty (an unset shell variable?): give office or a scene-graph "
            "file",
        ),
        (
            config.nav_layer is None or config.environment != "office",
            "--nav-layer needs a scene-graph file as --environment",
        ),
    ]
    for ok, message in checks:
        if not ok:
            raise InputError(message, hint="see aion simulate --help for every option's range")
    _check_tour_starts(config)
    if config.days * 86400.0 * config.rate_hz > MAX_TICKS:
        raise InputError(
            f"{config.days:g} days at {config.rate_hz:g} Hz is more than one scene holds "
            f"({MAX_TICKS:,} sensor ticks; the robot is simulated per tick in memory)",
            hint="simulate several scenes (--scenes) or lower --rate",
        )
    if config.robot == "fixed" and config.resolved_frame() == "base_link":
        raise InputError(
            "a fixed sensor publishes in the map frame",
            hint="drop --frame base_link or use --robot patrol",
        )
    flags = config.patrol.changed_flags() if config.robot == "fixed" else []
    if config.robot == "fixed" and config.stream.period_s != StreamConfig().period_s:
        flags.append("--dsg-period")  # the period while the robot drives
    if flags:  # a fixed sensor sees everyone at every tick: they would do nothing
        named = " and ".join([", ".join(flags[:-1]), flags[-1]] if len(flags) > 1 else flags)
        raise InputError(
            f"{named} set{'s' if len(flags) == 1 else ''} the patrolling robot, and "
            "--robot fixed has none: a fixed sensor sees every person at every tick",
            hint=f"leave out {named}, or use --robot patrol",
        )
    if config.timezone is not None and config.utc_offset_h != 0.0:
        raise InputError(
            "give --tz or --utc-offset, not both",
            hint="--tz Europe/London keeps the zone's daylight saving; --utc-offset 1 is "
            "a fixed offset",
        )
    detection_msgtype(config.detection_type)
    try:
        first = start_ns(config.start, config.utc_offset_h, config.timezone)
    except (OverflowError, OSError, ValueError) as exc:
        raise InputError(f"--start {config.start!r} cannot be simulated: {exc}") from exc
    if not 0 <= first <= LAST_START_NS - int(config.days * 86400e9):
        raise InputError(
            f"--start {config.start!r}: the simulated days must lie in 1970 .. 2261",
            hint="choose a later start" if first < 0 else "choose an earlier start",
        )


def _check_tour_starts(config: ScenarioConfig) -> None:
    """A patrol whose hours no tour start falls in: the robot would never leave its dock."""
    from aion_cli.sim.robot import tours_can_start

    if config.robot != "patrol" or tours_can_start(config.patrol):
        return
    lo, hi = config.patrol.hours
    every = config.patrol.tour_every_s / 60.0
    raise InputError(
        f"no patrol tour would start in --patrol-hours {lo:g}-{hi:g}: tours start every "
        f"{every:g} min (--tour-every) from 00:01 local time, and none falls in those hours",
        hint="0-24 is all day; START after END wraps past midnight (22-6); widen the hours "
        "or shorten --tour-every",
    )
