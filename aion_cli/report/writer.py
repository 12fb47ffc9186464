"""Writing a map report into a folder: ``index.html`` and the PNG pictures it shows.

Everything is written into a hidden staging folder beside ``OUT`` (``formats.outputs.Staged``,
as ``aion export`` does) and moved in when complete, so a failure (a bad map, a full disk,
Ctrl-C) leaves no partial report behind; files already in ``OUT`` that the report does not
write are kept, and a same-named file is replaced only when a report wrote it
(:func:`is_report_file`): nothing is moved in otherwise. ``OUT``'s lock
(:func:`formats.output_lock.output_lock`) is held meanwhile: a second report is refused.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from aion_cli.engine.time_text import Zone
from aion_cli.exports import check_out_dir, naming
from aion_cli.formats.output_lock import output_lock
from aion_cli.formats.outputs import Staged
from aion_cli.report.content import ROSES, ReportContent, gather
from aion_cli.report.page import FOOTER

PAGE = "index.html"
TIMELINE, ROSES_PNG, MAP_PNG = "observed.png", "roses.png", "map.png"
ACTIVITY, ACTIVITY_ROLES = "activity_{}.png", ("day_weekday", "day_weekend", "week")
"""The files a report writes (named once: the check before drawing and the drawing use them)."""
STEPS = 8
"""Calls of ``on_step`` a report makes (for a progress bar's total)."""


def write_report(
    loaded: Any,
    map_path: Any,
    out_dir: Path,
    zone: Zone,
    t_ns: int | None = None,
    on_step: Callable[[str], None] | None = None,
) -> list[Path]:
    """Write the report of ``loaded`` into ``out_dir`` (times in ``zone``; the busiest
    entries at ``t_ns``, None: as observed); the files written, ``index.html`` first.
    ``on_step(what)`` is called after each of the :data:`STEPS` steps."""
    from datetime import UTC, datetime

    from aion_cli import __version__
    from aion_cli.report import page, plots

    def step(what: str) -> None:
        if on_step is not None:
            on_step(what)

    check_out_dir(out_dir)
    if out_dir.is_dir():  # a file of someone else's under a name the report writes: refused
        from aion_cli.formats.outputs import check_replaceable  # before anything is drawn

        names = [PAGE, TIMELINE, ROSES_PNG, MAP_PNG, *(ACTIVITY.format(r) for r in ACTIVITY_ROLES)]
        check_replaceable((out_dir / name for name in names), is_report_file)
    content = gather(loaded, map_path, zone, t_ns)
    step("read the map")
    with (
        output_lock(out_dir, into=True),  # a second report into OUT is refused meanwhile
        naming(out_dir),  # a full disk's failed close names no file: OUT is named
        Staged(out_dir, merge=True, recognise=is_report_file) as staged,
    ):
        folder = staged.path
        folder.mkdir()
        pictures: dict[str, str | None] = {}
        pictures["timeline"] = plots.timeline_png(
            content.observed, zone, folder / TIMELINE
        ).name
        step("timeline")
        ylabel = f"detections per {content.window_s / 60:g} min"
        for role, series in zip(ACTIVITY_ROLES, content.activity, strict=False):
            pictures[role] = plots.activity_png(
                series, ylabel, folder / ACTIVITY.format(role), zone
            ).name
            step(f"activity: {series.title}")
        for _ in range(len(ACTIVITY_ROLES) - len(content.activity)):
            step("activity")
        roses = [b for b in content.busiest if b.record.get("flow")][:ROSES]
        pictures["roses"] = (
            plots.roses_png(roses, content.bins, folder / ROSES_PNG).name if roses else None
        )
        step("direction roses")
        pictures["topdown"] = top_down_picture(loaded, content, folder / MAP_PNG).name
        step("map from above")
        stamp = datetime.now(UTC).isoformat(sep=" ", timespec="seconds")
        (folder / PAGE).write_text(
            page.render(content, pictures, stamp, __version__), encoding="utf-8"
        )
        step("page")
        written = [folder / PAGE, *(folder / n for n in pictures.values() if n is not None)]
    return [out_dir / p.relative_to(folder) for p in written]


def is_report_file(path: Path) -> bool:
    """Whether ``path`` is a file a report wrote, which a new report may replace: a page with
    the report's footer, a picture aion drew, or a picture such a page beside it shows (the
    pictures of reports written before aion marked its pictures)."""
    from aion_cli.pictures.png_mark import is_aion_png

    if path.suffix.lower() != ".png":
        return FOOTER.encode() in _page_bytes(path)
    if is_aion_png(path):
        return True
    page = _page_bytes(path.parent / PAGE)
    return FOOTER.encode() in page and f'src="{path.name}"'.encode() in page


def _page_bytes(path: Path) -> bytes:
    """The first 4 MiB of a page (b"" when it cannot be read)."""
    try:
        with open(path, "rb") as fh:
            return fh.read(1 << 22)
    except OSError:
        return b""


def top_down_picture(loaded: Any, content: ReportContent, path: Path) -> Path:
    """The top-down picture of the map for the page (``aion export --format png``'s
    :func:`aion_cli.pictures.render.render_map_png`) at the report's time (as observed
    without one), written at ``path``."""
    from aion_cli.pictures.render import render_map_png

    # the picture escapes the name's $ itself
    return render_map_png(loaded, content.t_ns, content.zone, path, title=content.map_name)
