"""People-track files -> :class:`DetectionBatch`: one entry point for every layout.

:func:`read_track_data` (and :func:`read_tracks`, its detections only) reads a file of any of
:data:`formats.track_types.LAYOUTS` with the reader that knows it:

- :mod:`formats.track_csv`: the tables of one line per detection (``canonical``, ``atc``,
  ``thor``, ``eth`` / ``ucy``), their parsing, streaming (:func:`formats.track_csv.track_chunks`)
  and the canonical CSV writer;
- :mod:`formats.datasets`: the ``edinburgh``, ``thor-magni`` and ``lincoln`` datasets, which
  also say when the sensor was recording and leave notes for the user.

The types they share (:class:`formats.track_types.TrackData`,
:class:`formats.track_types.TracksFormatError`) are in :mod:`formats.track_types`; writing
tracks as a robot log that ``aion build`` reads is :mod:`formats.tracks_log`.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from aion_cli.engine.types import DetectionBatch
from aion_cli.formats.datasets import EDINBURGH_FPS, read_edinburgh, read_lincoln
from aion_cli.formats.thor_magni import read_thor_magni
from aion_cli.formats.track_csv import read_atc, read_canonical, read_eth
from aion_cli.formats.track_types import LAYOUTS, TrackData, TracksFormatError

if TYPE_CHECKING:
    from aion_cli.engine.tracking import LinkerConfig


def read_tracks(
    path: str | Path, layout: str = "canonical", start_ns: int = 0, fps: float | None = None
) -> DetectionBatch:
    """Read a tracks file of ``layout`` into a time-sorted :class:`DetectionBatch`.

    ``start_ns`` shifts THÖR / THÖR-MAGNI / ETH / UCY / ATC times and is when frame 0 of an
    Edinburgh file was captured (Lincoln times are UNIX already and are not shifted); ``fps``
    is the ETH/UCY (default 25) or Edinburgh (default about 9) frame rate.
    """
    return read_track_data(path, layout, start_ns, fps).batch


def read_track_data(
    path: str | Path,
    layout: str = "canonical",
    start_ns: int = 0,
    fps: float | None = None,
    linker: LinkerConfig | None = None,
    units: str = "auto",
) -> TrackData:
    """A tracks file of ``layout`` read whole: the time-sorted detections plus what the file
    says about itself: the Lincoln layout's declared and sentinel spans (:func:`read_lincoln`,
    linked with ``linker``), and notes (Edinburgh point counts, THÖR-MAGNI's skipped rows and
    agents and its length unit, ``units``); the other layouts declare nothing (``observed``
    empty). ``start_ns`` and ``fps`` as in :func:`read_tracks`."""
    key = layout.lower()
    if key == "canonical":
        return TrackData(read_canonical(path))
    if key in ("atc", "thor"):
        return TrackData(read_atc(path, start_ns, key))
    if key in ("eth", "ucy"):
        return TrackData(read_eth(path, 25.0 if fps is None else fps, start_ns, key))
    if key == "lincoln":
        return read_lincoln(path, linker)
    if key == "edinburgh":
        return read_edinburgh(path, start_ns, EDINBURGH_FPS if fps is None else fps)
    if key == "thor-magni":
        return read_thor_magni(path, start_ns, units)
    raise TracksFormatError(f"unknown tracks layout {layout!r}", hint=f"use {', '.join(LAYOUTS)}")
