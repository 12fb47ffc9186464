"""When a log without a robot trajectory recorded: ``aion info``'s ``fixed_sensor`` report.

A log without TF, and without a scene graph whose agent layer holds robot poses, is a fixed
sensor to the build, which observes the windows that hold a message; nothing else says what
it will observe. The hours are given in a zone (``aion info --tz``; UTC by default, the zone a
build takes without ``--tz``): a tracker kept to 07:00-10:00 in Berlin reads 07:00-10:00 in
Europe/Berlin on both sides of a daylight-saving change, where UTC shows 05:00-09:00.
"""

from __future__ import annotations

from typing import Any

from aion_cli.engine.types import I64


def fixed_sensor_windows(logset: Any, timezone: str = "UTC") -> dict[str, Any]:
    """How many of the default model's windows between the logs' first and last message
    hold a message, how much of them the logs recorded (``recorded_windows``, and in seconds
    ``recorded_s``: a window a log starts or ends inside counts for the part recorded, as a
    build counts it: a 255-second log recorded 0.43 of its one window), and at which hours of
    the day (in ``timezone``, per kind of day): without TF or a scene graph nothing else says
    what a build observed (it also leaves out stray messages a day away, which this count
    keeps)."""
    import numpy as np

    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.temporal.calendar import Calendar
    from aion_cli.engine.windows import window_centre_ns, window_ns
    from aion_cli.forecast_notes import observed_hours

    config = ModelConfig(timezone=timezone)
    delta = window_ns(config.window_s)
    windows = logset.recorded_windows(delta)
    span = int(windows[-1] - windows[0]) + 1 if windows.size else 0
    calendar = Calendar(config.timezone, config.profile, config.profile_bin_s)
    bins = np.unique(calendar.profile_bin(window_centre_ns(windows, delta)))
    hours = observed_hours({"observed_bins": bins.tolist()}, config.to_dict(), config.timezone)
    recorded = recorded_window_share(logset, windows, delta) if windows.size else 0.0
    return {"windows_with_messages": int(windows.size), "span_windows": span,
            "recorded_windows": round(recorded, 2),
            "recorded_s": round(recorded * config.window_s, 1), "window_s": config.window_s,
            "hours_with_messages": hours}


def recorded_window_share(logset: Any, windows: I64, delta: int) -> float:
    """How many windows of ``windows`` (sorted) the logs recorded, each window a log starts or
    ends inside counted for the part recorded (:func:`aion_cli.fixed_sensor.file_bounds`),
    as a build counts a fixed sensor's windows: a four-minute log records 0.4 of one
    ten-minute window."""
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.observation import ObservationSource
    from aion_cli.fixed_sensor import file_bounds

    source = ObservationSource()
    source.add_fixed_windows(windows, delta, file_bounds(logset, windows, delta))
    return float(source.fixed_share(windows, delta, ModelConfig()).sum())
