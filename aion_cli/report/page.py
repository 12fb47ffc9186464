"""The report's HTML: one page, inline CSS, no script, no external address.

The page refers only to the pictures written beside it (relative names handed in by the
writer). Every string that comes from the map (its file name, input names, room labels, ids,
config values, notes) goes through :func:`escape`, so a log named ``<b>&x.mcap`` shows
as written and never becomes markup, and a name whose bytes are not UTF-8 (a map or log named
``map\\xff.aion``) shows U+FFFD for them instead of making the page unwritable.
"""

from __future__ import annotations

import html
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from aion_cli.engine.time_text import Zone, format_ns
from aion_cli.formats.outputs import safe_text
from aion_cli.merge_names import shown_names
from aion_cli.note_words import EXTRAPOLATED
from aion_cli.number_text import fixed, span_text
from aion_cli.report.content import ReportContent

FOOTER = "<footer>written by aion "
"""How the page's last line begins: it marks a page as aion's (``report.writer`` replaces only
pages that carry it)."""


def escape(text: str) -> str:
    """``text`` as HTML text: markup characters escaped, undecodable name bytes as U+FFFD
    (:func:`formats.outputs.safe_text`; the page is written as UTF-8)."""
    return html.escape(safe_text(text))

CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; color: #1d2733;
  max-width: 1100px; margin: 2em auto; padding: 0 1em; line-height: 1.45; }
h1 { font-size: 1.6em; margin-bottom: 0.1em; } h2 { border-bottom: 1px solid #d6dde6;
  padding-bottom: 0.2em; margin-top: 2em; } .sub { color: #5b6b7c; margin-top: 0; }
table { border-collapse: collapse; margin: 0.6em 0 1.2em; font-size: 0.92em; }
th, td { border: 1px solid #d6dde6; padding: 0.25em 0.6em; text-align: left; }
th { background: #eef2f6; } td.n { text-align: right; font-variant-numeric: tabular-nums; }
.grid { display: flex; flex-wrap: wrap; gap: 2em; align-items: flex-start; }
figure { margin: 1em 0; } figure img { max-width: 100%; border: 1px solid #e1e6ec; }
figcaption { color: #44525f; font-size: 0.9em; max-width: 60em; }
code { background: #f3f5f7; padding: 0 0.25em; } .note { color: #8a5a00; }
footer { color: #7a8896; font-size: 0.85em; margin-top: 3em; }
"""
_NUMERIC = ' class="n"'


def render(
    content: ReportContent, pictures: Mapping[str, str | None], generated: str, version: str
) -> str:
    """The page of ``content``; ``pictures`` names the PNG files beside it by role
    (``timeline``, ``day_weekday``, ``day_weekend``, ``week``, ``roses``, ``topdown``; None
    or missing: not drawn)."""
    c = content
    when = (
        "busiest entries as observed (historical)"
        if c.t_ns is None
        else f"busiest entries predicted at {format_ns(c.t_ns, c.zone)}{_mark(c)}"
    )
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>aion map report: {escape(c.map_name)}</title>",
        f"<style>{CSS}</style></head><body>",
        f"<h1>Map report: <code>{escape(c.map_name)}</code></h1>",
        f'<p class="sub">times in {escape(c.zone.name)}; {escape(when)}</p>',
        *_holdings(c),
        *_topdown(c, pictures),
        *_observed(c, pictures),
        *_activity(c, pictures),
        *_busiest(c, pictures),
        f"{FOOTER}{escape(version)} on {escape(generated)}</footer>",
        "</body></html>",
    ]
    return "\n".join(parts) + "\n"


def _table(
    headers: Sequence[str], rows: Iterable[Sequence[Any]], table_id: str, numeric: set[int]
) -> str:
    """An HTML table; every cell escaped, the columns in ``numeric`` right-aligned."""
    head = "".join(f"<th>{escape(h)}</th>" for h in headers)
    body = []
    for row in rows:
        cells = "".join(
            f"<td{_NUMERIC if k in numeric else ''}>{escape(_text(v))}</td>"
            for k, v in enumerate(row)
        )
        body.append(f"<tr>{cells}</tr>")
    rows_html = "".join(body)
    head_html = f"<thead><tr>{head}</tr></thead>"
    return f'<table id="{table_id}">{head_html}<tbody>{rows_html}</tbody></table>'


def _text(value: Any) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    if isinstance(value, int) and not isinstance(value, bool):
        return f"{value:,}"
    return str(value)


def _figure(src: str | None, alt: str, caption: str) -> list[str]:
    if src is None:
        return []
    return [
        f'<figure><img src="{escape(src)}" alt="{escape(alt)}">',
        f"<figcaption>{caption}</figcaption></figure>",
    ]


def size_text(n: int) -> str:
    """Bytes as B / KiB / MiB / GiB."""
    value = float(n)
    for unit in ("B", "KiB", "MiB"):
        if value < 1024:
            return f"{value:.0f} {unit}" if unit == "B" else f"{value:.1f} {unit}"
        value /= 1024
    return f"{value:.1f} GiB"


def _when(t_ns: int | None, zone: Zone) -> str:
    return "-" if t_ns is None else format_ns(t_ns, zone)


def _holdings(c: ReportContent) -> list[str]:
    """What the map holds: counts, facts, inputs, model families."""
    from aion_cli.engine.config import ModelConfig
    from aion_cli.manifest import days_scored_text

    s = c.shown
    start, end = c.observed.span
    seconds = None if start is None or end is None else (end - start) / 1e9
    defaults = ModelConfig().parameters()
    changed = {k: v for k, v in (s.get("config") or {}).items() if defaults.get(k) != v}
    facts = [
        ("format", f"{s.get('format', '-')} {s.get('version', '')}".strip()),
        ("created", f"{s.get('created', '-')} by {s.get('creator', '-')}"),
        (
            "time span",
            f"{_when(start, c.zone)} .. {_when(end, c.zone)}"
            + ("" if seconds is None else f" ({span_text(seconds)})"),
        ),
        (
            "first / last observed window (centres)",
            f"{_when(c.observed.first_ns, c.zone)} / {_when(c.observed.last_ns, c.zone)}",
        ),
        ("observation", s.get("observation", "-")),
        # the days the day-ahead scoring judged: an entry leaves static only on them
        *([("days scored", scored)] if (scored := days_scored_text(s)) is not None else []),
        ("scene graph", s.get("graph_source", "-")),
        # the frame of every position on the page (aion build --map-frame)
        *([("map frame", str(s["map_frame"]))] if s.get("map_frame") else []),
        *_made_by(s),
        ("map time zone", s.get("timezone") or "not set (queries use the local zone)"),
        ("config", ", ".join(f"{k}={v}" for k, v in changed.items()) or "defaults"),
    ]
    logs = s.get("inputs", [])
    inputs = [  # named as aion info names them: by path where two share a file name
        (shown, size_text(int(i.get("size", 0))), str(i.get("sha256", ""))[:12])
        for i, shown in zip(logs, shown_names(logs), strict=True)
    ]
    maps = s.get("merged_from") or []
    merged = [  # the maps aion merge joined, as aion info lists them
        (shown, size_text(int(m.get("size", 0))), str(m.get("sha256", ""))[:12])
        for m, shown in zip(maps, shown_names(maps), strict=True)
    ]
    families = s.get("families") or {}
    flow, direction = families.get("flow") or {}, families.get("direction") or {}
    names = sorted(set(flow) | set(direction))
    out = [
        "<h2>What the map holds</h2>",
        '<div class="grid"><div>',
        _table(("what", "count"), c.counts.items(), "counts", {1}),
        "</div><div>",
        _table(("what", "value"), facts, "facts", set()),
        "</div></div>",
        "<h3>Inputs</h3>",
        _table(("log", "size", "sha256"), inputs, "inputs", {1}),
        *(["<p>Merged from these maps:</p>", _table(("map", "size", "sha256"), merged, "merged",
                                                    {1})] if merged else []),
        "<h3>Temporal model families</h3>",
        "<p>How many entries each family forecasts (as <code>aion info</code> shows them): "
        "the flow (how many people) and the direction histogram are chosen separately, per "
        "entry, by their day-ahead scores.</p>",
        _table(
            ("family", "flow", "direction"),
            ((n, flow.get(n, 0), direction.get(n, 0)) for n in names),
            "families",
            {1, 2},
        ),
    ]
    if families:
        reconciled = "yes" if families.get("reconciled") else "no"
        out.append(f"<p>Totals reconciled to the map's own forecast: {reconciled}.</p>")
    return out


def _made_by(s: Mapping[str, Any]) -> list[tuple[str, str]]:
    """The facts rows of a merged map (``merged from``) and a query-only one (``query
    only``), worded as ``aion info`` words them."""
    from aion_cli.merge_names import merged_from_text
    from aion_cli.query_only import query_only_text

    rows = []
    if s.get("merged_from"):
        rows.append(("merged from", merged_from_text(len(s["merged_from"]), s.get("lineage"))))
    if isinstance(s.get("query_only"), dict):
        rows.append(("query only", query_only_text(s["query_only"])))
    return rows


def _observed(c: ReportContent, pictures: Mapping[str, str | None]) -> list[str]:
    o = c.observed
    fixed = len(o.fixed[0])
    coverage = (
        f"blue: the {fixed:,} fixed-sensor interval(s) the map holds (every place observed)"
        if fixed
        else "the robot's coverage is kept as tallies per place, not as a list of windows, "
        "so no intervals are drawn"
    )
    caption = (
        f"Left: one row per day ({escape(c.zone.name)}), time of day across; grey: the span of "
        f"the logs; {coverage}; red triangles: the first and last observed window. Right: the "
        "hours observed in each profile bin (hour of the day, by day type): the most any "
        "place or cell of the map was observed in that bin; the periodic models learn their "
        "daily rhythm from these bins, so an empty bin is one the map can only guess. "
        "Observation: "
        f"<code>{escape(o.source)}</code>."
    )
    return [
        "<h2>When it was observed</h2>",
        *_figure(pictures.get("timeline"), "observed windows", caption),
    ]


def _activity(c: ReportContent, pictures: Mapping[str, str | None]) -> list[str]:
    out = ["<h2>Activity over the day and the week</h2>"]
    out += [f'<p class="note">{escape(n)}</p>' for n in c.notes]
    if not c.activity:
        return out
    window = f"{c.window_s / 60:g}-minute"
    lines = "one line per room (the busiest, the others summed)"
    summed = "summed over each room's places as <code>aion predict --layer rooms</code> sums them"
    if c.activity[0].names == ("whole map",):  # no room (or none holding a place)
        lines = "the whole map's flow"
        summed = "summed over every entry <code>aion predict</code> lists, places and hash cells"
    grey = ""
    if any(s.unobserved is not None and s.unobserved.any() for s in c.activity):
        grey = (
            " Grey bands, dotted curves: hours of the day no log observed on any day; the "
            "forecast there is extrapolated from the hours observed, not measured."
        )
    if any(s.other_days is not None and s.other_days.any() for s in c.activity):
        seen = f" (it observed {escape(c.hours_observed)})" if c.hours_observed else ""
        grey += (
            " Hatched bands, dotted curves: hours of a kind of day the map never observed at "
            f"that hour{seen}; the forecast there follows the rhythm of the days it saw, not "
            "measured."
        )
    out.append(
        f"<p>Predicted flow (expected detections per {window} window, {summed}), "
        f"{lines}.{grey}</p>"
    )
    roles = ("day_weekday", "day_weekend", "week")
    steps = ("every 15 minutes", "every 15 minutes", "every hour")
    for series, role, step in zip(c.activity, roles, steps, strict=False):
        out += _figure(
            pictures.get(role),
            f"activity {series.title}",
            f"{escape(series.title)}: the forecast {step} ({escape(c.zone.name)}).",
        )
    return out


def _mark(c: ReportContent) -> str:
    """`` (extrapolated: an hour no log observed)`` after the time of a report whose hour no
    day observed (as ``aion predict --time``'s table titles it), else nothing."""
    return f" {EXTRAPOLATED}" if c.hour_observed is False else ""


def _busiest(c: ReportContent, pictures: Mapping[str, str | None]) -> list[str]:
    what = (
        "as observed (detections per window over the windows each entry was observed)"
        if c.t_ns is None
        else f"predicted at {escape(format_ns(c.t_ns, c.zone) + _mark(c))}"
    )
    command = f"aion predict --top {len(c.busiest)} " + (
        "--historical" if c.t_ns is None else f'--time "{format_ns(c.t_ns, c.zone)}"'
    )
    if not c.busiest:
        return [
            "<h2>Busiest places</h2>",
            f"<p>None of the map's {c.matched:,} places and hash cells has any flow {what}.</p>",
        ]
    rows = []
    for rank, b in enumerate(c.busiest, start=1):
        r = b.record
        direction = r.get("direction_deg")
        rows.append(
            (
                rank,
                r["id"],
                r["kind"],
                b.room or "-",
                None if r.get("flow") is None else f"{r['flow']:.3f}",
                None if r.get("flow_per_hour") is None else f"{r['flow_per_hour']:.2f}",
                None if r.get("entropy") is None else f"{r['entropy']:.3f}",
                None if direction is None else fixed(direction, 1, sign=True),
                b.family,
                f"{fixed(r['x'], 2)}, {fixed(r['y'], 2)}",  # as predict's table (cells at .25)
            )
        )
    headers = (
        "#",
        "id",
        "kind",
        "room",
        "flow / window",
        "flow / h",
        "entropy",
        "direction (deg)",
        "family",
        "where (x, y m)",
    )
    caption = (
        "The dominant direction of each: the histogram of the directions people walked, as "
        "bars around the place (east = +x, counter-clockwise), the red arrow the dominant "
        "direction (where most people walk, as the table gives it), as long as the flow is "
        "concentrated (short when people walk both ways); the rings give the share of the "
        "place's headings in a direction, on one scale for every rose."
    )
    return [
        "<h2>Busiest places</h2>",
        f"<p>The {len(c.busiest)} busiest of the map's {c.matched:,} places and hash cells, "
        f"{what}, as <code>{escape(command)}</code> lists them; entropy 0 "
        "means everyone walks one way, 1 every way; direction in degrees counter-clockwise "
        "from +x; family: the temporal model forecasting the flow.</p>",
        _table(headers, rows, "busiest", {0, 4, 5, 6, 7}),
        *_figure(pictures.get("roses"), "direction roses", caption),
    ]


def _topdown(c: ReportContent, pictures: Mapping[str, str | None]) -> list[str]:
    src = pictures.get("topdown")
    if src is None:
        return []
    when = "as observed" if c.t_ns is None else f"predicted at {format_ns(c.t_ns, c.zone)}"
    caption = (
        f"The places and hash cells seen from above, {escape(when)} (as <code>aion export "
        "--format png</code> draws them): an arrow along each one's dominant direction, as "
        "long as its flow, coloured by direction entropy (blue: everyone walks one way, red: "
        "every way); the legend under the picture names the other colours it draws"
        f"{'; dashed outlines: the rooms' if c.counts.get('rooms') else ''}."
    )
    return ["<h2>The map from above</h2>", *_figure(src, "top-down map", caption)]
