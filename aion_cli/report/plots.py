"""The report's pictures as PNG files: matplotlib ``Figure`` objects drawn on the Agg canvas
(no pyplot, so no global figure state and no display is ever needed).

* :func:`timeline_png` — when the map was observed: one row per local day (time of day
  across), the logs' span and the fixed-sensor intervals, beside the hours observed per
  profile bin that the periodic models learn from;
* :func:`activity_png` — predicted flow per room over a day or a week, one line per room;
* :func:`roses_png` — direction roses (polar bars of the direction histograms) of the
  busiest entries.

Strings from the map (room labels, ids) reach matplotlib through :func:`plain`, so a ``$``
in a label is drawn as a dollar sign, not read as mathtext.
"""

from __future__ import annotations

from collections.abc import Sequence
from datetime import timedelta
from pathlib import Path
from typing import Any

import numpy as np

from aion_cli.engine.time_text import Zone, from_ns
from aion_cli.formats.scene_colours import NO_HEADING_TEAL
from aion_cli.pictures.layout import shortened  # a room name cut to a width (also the maps')
from aion_cli.report.content import Busiest, Observed, Series, local_midnight

DPI = 110
_NS = 1_000_000_000
_SPAN_GREY = "#c9d3df"
_FIXED_BLUE = "#2c6fbb"
_MAX_DAY_ROWS = 120
NO_HEADING_ROSE = "no heading:\npeople standing\nstill or untracked"
"""The text of the rose of an entry with flow but no direction (its histogram is empty)."""
ROSES_CAPTION = (
    "rings: share of the place's headings in that direction (same scale on every rose)"
)
"""The caption under the roses."""
ROSE_TITLE_CHARS = 34
"""The longest room name a rose's title shows (about the rose's width at 9 points)."""
RING_LABEL_LIFT_PT = 6.0
UNOBSERVED_LABEL = "hours no log observed (extrapolated, dotted)"
"""The legend of an activity chart's grey bands: hours of the day no kind of day observed."""
OTHER_DAYS_LABEL = (
    "a kind of day the map did not observe at this hour\n(follows the days seen, dotted)"
)
"""The legend of its hatched bands: hours only another kind of day observed (a Saturday from a
map of weekdays), where the forecast follows the rhythm of the days the map saw."""
"""How far (points) a rose's outer ring label is moved out, clear of the circle."""


def plain(text: object) -> str:
    """``text`` as literal matplotlib text: ``$`` escaped (mathtext is off for it), a name's
    bytes that are not UTF-8 as U+FFFD (:func:`formats.outputs.safe_text`; matplotlib
    refuses them)."""
    from aion_cli.formats.outputs import plain_text

    return plain_text(text)


def _figure(width: float, height: float) -> Any:
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height), dpi=DPI, layout="constrained")


def _save(fig: Any, path: Path) -> Path:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(fig)
    from aion_cli.pictures.png_mark import save_marked_png

    save_marked_png(fig, path, dpi=DPI)
    return path


def timeline_png(observed: Observed, zone: Zone, path: Path) -> Path:
    """Days (rows, in ``zone``) x time of day: the logs' span in grey, fixed-sensor intervals
    in blue, the first and last observed window marked; beside it a heat map of the hours
    observed per profile bin (the map's own zone)."""
    days = (
        1
        if observed.first_ns is None or observed.last_ns is None
        else ((observed.last_ns - observed.first_ns) // (86_400 * _NS) + 2)
    )
    fig = _figure(10.0, min(max(2.4 + 0.3 * days, 3.0), 9.0))
    grid = fig.add_gridspec(1, 2, width_ratios=(1.25, 1.0))
    _days_panel(fig.add_subplot(grid[0, 0]), observed, zone)
    _profile_panel(fig, fig.add_subplot(grid[0, 1]), observed)
    return _save(fig, path)


def _days_panel(ax: Any, observed: Observed, zone: Zone) -> None:
    start, end = observed.span
    marks = [t for t in (start, end, observed.first_ns, observed.last_ns) if t is not None]
    if not marks:
        ax.text(0.5, 0.5, "nothing observed", ha="center", va="center", transform=ax.transAxes)
        ax.set_axis_off()
        return
    first_day = from_ns(min(marks), zone).date()
    last_day = from_ns(max(marks), zone).date()
    total = (last_day - first_day).days + 1
    days = min(total, _MAX_DAY_ROWS)
    # a longer observation shows its last days (what the forecast learnt from last), titled
    # so: the rows stopped at the first days without a word, the last window off the picture
    first_day = last_day - timedelta(days=days - 1)
    starts, ends = observed.fixed
    for row in range(days):
        day = first_day + timedelta(days=row)
        lo, hi = local_midnight(day, zone), local_midnight(day + timedelta(days=1), zone)
        hours = (hi - lo) / 3600 / _NS
        if start is not None and end is not None:
            _bars(ax, row, [max(start, lo)], [min(end, hi)], lo, hours, _SPAN_GREY, 0.8)
        keep = (ends > lo) & (starts < hi)
        if keep.any():
            _bars(
                ax,
                row,
                np.maximum(starts[keep], lo),
                np.minimum(ends[keep], hi),
                lo,
                hours,
                _FIXED_BLUE,
                0.5,
            )
    for t, label in ((observed.first_ns, "first"), (observed.last_ns, "last")):
        if t is not None:
            local = from_ns(t, zone)
            row = (local.date() - first_day).days
            x = local.hour + local.minute / 60 + local.second / 3600
            ax.plot(
                [x],
                [row],
                marker="v" if label == "first" else "^",
                color="#c0392b",
                markersize=7,
                linestyle="none",
            )
    ax.set_xlim(0, 24)
    ax.set_xticks(range(0, 25, 3))
    ax.set_ylim(days - 0.5, -0.5)
    step = max(1, days // 14)
    ticks = list(range(0, days, step))
    ax.set_yticks(ticks)
    ax.set_yticklabels([f"{first_day + timedelta(days=r):%a %Y-%m-%d}" for r in ticks], fontsize=8)
    ax.set_xlabel(f"time of day ({plain(zone.name)})")
    ax.set_title(
        "observed span per day"
        + (f" (the last {days} of {total} days)" if total > days else ""),
        fontsize=10,
    )
    ax.grid(axis="x", color="#dddddd", linewidth=0.6)


def _bars(
    ax: Any, row: int, lo: Any, hi: Any, midnight: int, hours: float, color: str, height: float
) -> None:
    """Horizontal bars ``[lo, hi)`` (UNIX ns) on day ``row``, x in hours since midnight."""
    a = (np.asarray(lo, dtype=np.float64) - midnight) / 3600 / _NS
    b = (np.asarray(hi, dtype=np.float64) - midnight) / 3600 / _NS
    ok = b > a
    if ok.any():
        x0 = a[ok] * 24 / hours
        ax.barh(
            np.full(int(ok.sum()), row),
            (b[ok] - a[ok]) * 24 / hours,
            left=x0,
            height=height,
            color=color,
            linewidth=0,
        )


def _profile_panel(fig: Any, ax: Any, observed: Observed) -> None:
    hours = np.asarray(observed.hours, dtype=np.float64)
    most = float(np.nanmax(hours)) if hours.size and np.isfinite(hours).any() else 0.0
    image = ax.imshow(
        hours,
        aspect="auto",
        cmap="Blues",
        vmin=0.0,
        # none observed: 0 to 1 hour, every bin white (matplotlib widened 0..0 to -0.1..0.1
        # and painted the bins its middle blue)
        vmax=most if most > 0 else 1.0,
        extent=(0, 24, hours.shape[0] - 0.5, -0.5),
        interpolation="nearest",
    )
    ax.set_yticks(range(hours.shape[0]))
    ax.set_yticklabels(observed.day_types, fontsize=8)
    ax.set_xticks(range(0, 25, 3))
    ax.set_xlabel(f"hour of day ({plain(observed.model_zone)}, the map's zone)")
    ax.set_title("hours observed per profile bin", fontsize=10)
    bar = fig.colorbar(image, ax=ax, shrink=0.9)
    bar.set_label("hours observed")


def _clock_hours(times: Any, zone: Zone) -> Any:
    """Hours of the wall clock in ``zone`` since the first time's local midnight, per time (a
    day's curve reads 0..24 by the clock on a day of 23 or 25 hours too)."""
    if not times.size:
        return times.astype(np.float64)
    first = from_ns(int(times[0]), zone).date()
    out = []
    for t in times.tolist():
        local = from_ns(int(t), zone)
        days = (local.date() - first).days
        out.append(days * 24 + local.hour + local.minute / 60 + local.second / 3600)
    return np.asarray(out, dtype=np.float64)


def activity_png(series: Series, ylabel: str, path: Path, zone: Zone) -> Path:
    """One line per column of ``series`` against the time (hours of the day for a day, days
    of the week for a week; in ``zone``)."""
    fig = _figure(10.0, 3.6)
    ax = fig.add_subplot()
    times = np.asarray(series.times_ns, dtype=np.int64)
    hours = _clock_hours(times, zone)
    week = times.size and hours[-1] > 24
    guessed = _flags(series.unobserved, times.size) | _flags(series.other_days, times.size)
    # the extrapolated stretches dotted, joined to the measured ones at their ends
    near = guessed | np.r_[guessed[1:], False] | np.r_[False, guessed[:-1]]
    for k, name in enumerate(series.names):
        flow = np.asarray(series.flows[:, k], dtype=np.float64)
        (line,) = ax.plot(
            hours,
            np.where(guessed, np.nan, flow),
            label=plain(name),
            linewidth=1.4,
            linestyle="--" if name.startswith("other rooms") else "-",
        )
        if guessed.any():
            ax.plot(
                hours,
                np.where(near, flow, np.nan),
                color=line.get_color(),
                linewidth=1.0,
                linestyle=":",
            )
    _shade(ax, hours, series.unobserved, UNOBSERVED_LABEL, color="#d9d9d9", alpha=0.6)
    _shade(ax, hours, series.other_days, OTHER_DAYS_LABEL, facecolor="none",
           edgecolor="#9a9a9a", hatch="//")
    if week:
        start = from_ns(int(times[0]), zone).date()
        ax.set_xticks(np.arange(0, 7 * 24 + 1, 24))
        ax.set_xticklabels([f"{start + timedelta(days=d):%a %d}" for d in range(8)])
        ax.set_xlim(0, 7 * 24)
        ax.set_xlabel(f"day ({plain(zone.name)}, from midnight)")
    else:
        ax.set_xticks(range(0, 25, 2))
        ax.set_xlim(0, 24)
        ax.set_xlabel(f"hour of day ({plain(zone.name)})")
    ax.set_ylabel(ylabel)
    ax.set_ylim(bottom=0)
    ax.set_title(plain(series.title), fontsize=10)
    ax.grid(color="#e3e3e3", linewidth=0.6)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.0, 1.0), frameon=False)
    return _save(fig, path)


def _flags(flags: Any, n: int) -> Any:
    """``flags`` (one per time) as a boolean array; all False when not known (None)."""
    return np.zeros(n, bool) if flags is None else np.asarray(flags, bool).reshape(-1)


def _shade(ax: Any, hours: Any, flags: Any, label: str, **style: Any) -> None:
    """Bands (``style``: grey, or hatched) over the runs of times ``flags`` marks (each time
    stands for the step up to the next), labelled once in the legend."""
    if flags is None or not np.any(flags) or len(hours) == 0:
        return
    marked = np.asarray(flags, bool)
    step = float(hours[1] - hours[0]) if len(hours) > 1 else 1.0
    edges = np.flatnonzero(np.diff(np.r_[0, marked.astype(np.int8), 0]))
    for k, (a, b) in enumerate(zip(edges[::2], edges[1::2], strict=True)):
        ax.axvspan(
            float(hours[a]),
            float(hours[b - 1]) + step,
            linewidth=0,
            label=label if k == 0 else None,
            **style,
        )


def roses_png(rows: Sequence[Busiest], bins: int, path: Path) -> Path:
    """A polar bar chart of the direction histogram of each of ``rows`` (bin b centred at
    -180 + (b + 0.5)·360/B degrees, counter-clockwise from +x, east at the right), the grid
    lines on the bins' edges."""
    from aion_cli.pictures.layout import wrapped

    n = max(len(rows), 1)
    cols = min(n, 3)
    fig = _figure(3.2 * cols, 3.2 * ((n + cols - 1) // cols))
    # a polar axes raises its title over the "90°" label after the constrained layout has
    # placed it: without a wider margin a row of two or three titles ran past the top edge
    fig.get_layout_engine().set(h_pad=0.1)
    centres = np.radians(-180.0 + (np.arange(bins) + 0.5) * 360.0 / bins)
    # grid lines at the bins' edges (matplotlib's every 45 degrees cut a 6-bin map's 60-degree
    # bars in two); the labels stay every 45 degrees (the 90 degrees one keeps the title clear)
    edges = np.radians(-180.0 + np.arange(bins) * 360.0 / bins) % (2 * np.pi)
    hists = [np.nan_to_num(np.asarray(row.record["histogram"], dtype=np.float64)) for row in rows]
    # one radial scale for every rose, rings at round shares: without it a rose 50 % one way
    # looked like one 20 % one way (each filled its own axes)
    rings = share_rings(max((float(h.max()) for h in hists if h.size), default=0.0))
    for k, (row, hist) in enumerate(zip(rows, hists, strict=True)):
        ax = fig.add_subplot((n + cols - 1) // cols, cols, k + 1, projection="polar")
        ax.bar(centres, hist, width=2 * np.pi / bins * 0.9, color="#2c6fbb", alpha=0.85)
        if not hist.any():  # an empty rose said nothing: flow without a heading, or none
            flowing = float(row.record.get("flow") or 0.0) > 0
            text, colour = (NO_HEADING_ROSE, NO_HEADING_TEAL) if flowing else ("no flow", "0.4")
            ax.text(0.5, 0.5, text, transform=ax.transAxes, ha="center", va="center",
                    fontsize=8, color=colour, bbox={"facecolor": "white", "edgecolor": "none"})
        angle = row.record.get("direction_deg")
        length = hist.max() * float(row.record.get("concentration") or 0.0)
        if angle is not None and length > 0:  # the dominant direction, as long as it is strong
            ax.annotate(
                "",
                xy=(np.radians(angle), length),
                xytext=(0, 0),
                arrowprops={"arrowstyle": "->", "color": "#c0392b", "linewidth": 1.6},
            )
        ax.set_theta_zero_location("E")
        ax.set_theta_direction(1)
        ax.xaxis.remove_overlapping_locs = False  # an edge on a labelled angle keeps its line
        ax.set_xticks(edges, minor=True)  # the bins' edges: each bar fills one sector
        ax.xaxis.grid(False, which="major")
        ax.xaxis.grid(True, which="minor")
        ax.set_ylim(0.0, float(rings[-1]))
        ax.set_yticks(rings)
        ax.set_yticklabels([f"{100 * r:.0f} %" for r in rings])
        ax.set_rlabel_position(67.5)
        labels = ax.get_yticklabels()
        for label in labels:
            label.set_bbox({"facecolor": "white", "edgecolor": "none", "alpha": 0.7, "pad": 0.5})
        # the outer ring's label ("100 %") sat on the circle, crossed by it and the bins'
        # grid lines: lifted clear of it (up and outward, along the labels' 67.5 degrees)
        labels[-1].set_transform(labels[-1].get_transform() + _outer_lift(fig))
        ax.tick_params(labelsize=7)
        # the room on a line of its own, shortened to the rose's width: on one line a long
        # room name ran into the next rose's title and past the picture's edges
        room = shortened(row.room, ROSE_TITLE_CHARS)
        title = rose_title(row.record) + (f"\n{room}" if room else "")
        ax.set_title(plain(title), fontsize=9)
    # broken to the page's width: under one rose (3.2 inches) the line ran past both edges
    fig.supxlabel(wrapped([ROSES_CAPTION], fig.get_figwidth(), 8), fontsize=8)
    return _save(fig, path)


def _outer_lift(fig: Any) -> Any:
    """The shift (outward along 67.5 degrees) that takes a rose's outer ring label
    clear of the circle it labels."""
    from matplotlib.transforms import ScaledTranslation

    lift = RING_LABEL_LIFT_PT / 72.0
    return ScaledTranslation(lift * np.cos(np.radians(67.5)), lift * np.sin(np.radians(67.5)),
                             fig.dpi_scale_trans)


def share_rings(top: float) -> Any:
    """The rings of a rose whose longest bar is the share ``top`` (0..1): multiples of the
    smallest round step (1, 2, 5, 10, 20, 25 %) giving at most five rings, the last at or
    beyond ``top``; one 100 % ring (a full rose) when nothing is above zero."""
    if not top > 0.0:
        return np.array([1.0])
    top = min(top, 1.0)
    step = next(s for s in (0.01, 0.02, 0.05, 0.1, 0.2, 0.25) if np.ceil(top / s - 1e-9) <= 5)
    count = int(np.ceil(top / step - 1e-9))
    return np.round(step * np.arange(1, count + 1), 6)


def rose_title(record: dict[str, Any]) -> str:
    """A rose's title: a node's id (``p12``); a hash cell by where it is, ``cell at (x, y)``
    in metres (its id is a 19-digit spatial-hash key, which says nothing to a reader)."""
    x, y = record.get("x"), record.get("y")
    if record.get("kind") == "cell" and x is not None and y is not None:
        return f"cell at ({float(x):.2f}, {float(y):.2f}) m"  # 0.5 m cells: centres at .25
    return str(record["id"])
