"""Issue 15's map size: what a smaller layout of the per-entry Fourier sums would save.

``temporal_cnt_fourier`` (one complex sum per (entry, value bin) pair and FreMEn period) is
most of a map's bytes. :func:`layout_figures` measures, on a map file, each candidate layout
against the stored one (docs/BENCHMARKS.md, stop 67):

* **zero rows** — the (entry, value bin) pairs that never counted a detection (the sparse
  layout of 2026-12-01 already leaves them out) and stored rows that are all zeros;
* **duplicate rows** — stored rows byte-equal to another one (pairs of one detection in the
  same window);
* **deflate** — zip deflate (zlib level 6) of the Fourier members only, and of every member
  where it saves at least a quarter within the readers' limit on expansion (not what aion
  writes: its members are stored and aligned so that a query maps them in place;
  :func:`deflated_copy` writes such a copy of a map, for timing queries on it);
* **window lists** — a pair's sums are Σ_w n_w e^{iω t_w} over the windows it counted
  detections in: a pair holding (window ``uint32``, count ``uint16``) per such window and a
  4-byte offset, where cheaper than its K sums, gives them back to rounding. The map keeps no
  such lists (a new accumulator); the bounds are from its profile counts (windows with
  detections >= profile bins with detections, <= detections).

:func:`template_slot_histograms` replays the benchmark map's history (``bench_temporal``'s
64 templates, which ``bench_engine.build_state`` tiles over every entry) for the exact window
lists, and checks the sums recomputed from them against the accumulated ones; also from the
counts per slot of the week (1,008 at 600 s; every default period, 24 h/k and 7 d/k, divides
a week), which would not grow with the map's span, but the periods are stored rounded to
10^-6 s (24 h/7 is not a whole number of them), so phases a week apart differ.

Run: ``python -m benchmarks.bench_map_layout [MAP ...]``: the given maps, else the 10^4-entry
benchmark map, ``samples/office.mcap``'s and, with ``AION_SHARED_DATA``, Lincoln's.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np

WEEK_SLOTS_BYTES = 4
"""Bytes per slot of a slot histogram: a uint16 slot of the week and a uint16 count."""
WINDOW_BYTES = 6
"""Bytes per window of a window list: a uint32 window index and a uint16 count."""
ROW_OFFSET_BYTES = 4
"""Bytes per pair of a slot histogram: where its slots start."""


def _deflated(data: bytes) -> int:
    return len(zlib.compress(data, 6))


def _pays(raw: int, deflated: int) -> bool:
    """Whether deflating a member of ``raw`` bytes to ``deflated`` saves a quarter of it and
    stays within what aion's readers accept (``formats.mapfile_format``: a member above
    ``RATIO_MIN_BYTES`` may expand at most ``DEFAULT_MAX_RATIO`` times; 90 here)."""
    from aion_cli.formats.mapfile_format import DEFAULT_MAX_RATIO, RATIO_MIN_BYTES

    bounded = raw <= RATIO_MIN_BYTES or raw <= 0.9 * DEFAULT_MAX_RATIO * deflated
    return deflated <= 0.75 * raw and bounded


def deflated_copy(source: Path, target: Path) -> tuple[int, int]:
    """``source`` rewritten with every member deflated where :func:`_pays`, the others stored
    (aion reads deflated members: ``formats/MAPFILE.md``); the two files' sizes."""
    import zipfile

    with zipfile.ZipFile(source) as zin, zipfile.ZipFile(target, "w", allowZip64=True) as zout:
        for info in zin.infolist():
            data = zin.read(info.filename)
            member = info.filename != "manifest.json"
            pays = member and _pays(len(data), _deflated(data))
            method = zipfile.ZIP_DEFLATED if pays else zipfile.ZIP_STORED
            zout.writestr(info.filename, data, compress_type=method)
    return source.stat().st_size, target.stat().st_size


def _duplicate_share(rows: np.ndarray) -> float:
    """Share of the rows byte-equal to an earlier row."""
    if rows.shape[0] == 0:
        return 0.0
    flat = np.ascontiguousarray(rows).reshape(rows.shape[0], -1)
    as_bytes = flat.view(np.dtype((np.void, flat.dtype.itemsize * flat.shape[1]))).reshape(-1)
    return 1.0 - np.unique(as_bytes).size / rows.shape[0]


def histogram_bytes(slots: np.ndarray, periods: int, per_slot: int = WEEK_SLOTS_BYTES) -> int:
    """Bytes of per-pair histograms of ``slots`` slots with detections each (``per_slot``
    bytes each), a pair keeping its ``periods`` complex sums where they are fewer bytes."""
    per_pair = np.minimum(16 * periods, per_slot * slots + ROW_OFFSET_BYTES)
    return int(per_pair.sum())


def layout_figures(path: Path) -> dict[str, Any]:
    """The candidate layouts' savings on the map file at ``path`` (the module docstring)."""
    from aion_cli.formats.mapfile import read_manifest, read_map

    size = path.stat().st_size
    config = read_manifest(path)["config"]
    arrays, _ = read_map(path)
    rows = int(arrays["entry_kind"].size)
    values = int(config["bins"]) + 1
    fourier, observed = arrays["temporal_cnt_fourier"], arrays["temporal_obs_fourier"]
    periods = int(fourier.shape[1])
    counts = arrays["temporal_cnt_profile"].astype(np.float64)
    detections = counts.sum(axis=1)
    member_bytes = {name: int(a.nbytes) for name, a in arrays.items()}
    deflated = {name: _deflated(np.ascontiguousarray(a).tobytes()) for name, a in arrays.items()}
    fourier_names = ("temporal_cnt_fourier", "temporal_obs_fourier")
    fourier_saved = sum(member_bytes[n] - min(deflated[n], member_bytes[n]) for n in fourier_names)
    where_it_pays = sum(
        b - deflated[n] for n, b in member_bytes.items() if _pays(b, deflated[n])
    )
    lowest = np.count_nonzero(counts, axis=1)  # windows with detections, at least
    highest = detections.astype(np.int64)  # and at most
    return {
        "map": str(path),
        "file_bytes": size,
        "entries": rows,
        "bytes_per_entry": size / max(rows, 1),
        "cnt_fourier_bytes_per_entry": fourier.nbytes / max(rows, 1),
        "obs_fourier_bytes_per_entry": observed.nbytes / max(rows, 1),
        "pairs": rows * values,
        "pairs_stored": int(fourier.shape[0]),
        "pairs_never_counted": 1.0 - fourier.shape[0] / max(rows * values, 1),
        "stored_rows_all_zero": int(np.count_nonzero(~fourier.any(axis=1))),
        "duplicate_cnt_rows": _duplicate_share(fourier),
        "duplicate_obs_rows": _duplicate_share(observed),
        "pairs_of_one_detection": float(np.mean(detections == 1)) if detections.size else 0.0,
        "deflate_fourier_saves": fourier_saved / size,
        "cnt_fourier_deflated_ratio": deflated["temporal_cnt_fourier"] / fourier.nbytes
        if fourier.nbytes
        else None,
        "deflate_where_it_pays_saves": where_it_pays / size,
        "window_lists_save_at_most": (
            fourier.nbytes - histogram_bytes(lowest, periods, WINDOW_BYTES)
        ) / size,
        "window_lists_save_at_least": (
            fourier.nbytes - histogram_bytes(highest, periods, WINDOW_BYTES)
        ) / size,
    }


def template_slot_histograms() -> dict[str, Any]:
    """The benchmark map's slot histograms, exactly: its 64 templates' history replayed
    (``bench_temporal.history_state`` on the templates alone, the days of
    ``bench_engine.build_state``); the bytes they would take per entry, and the largest
    difference between the sums recomputed from them and the accumulated ones, relative to
    the pair's detections (the sums' scale)."""
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.temporal.params import TemporalParams
    from aion_cli.engine.windows import window_centre_ns, window_ns
    from benchmarks.bench_engine import T0_NS
    from benchmarks.bench_temporal import (
        HISTORY_DAYS,
        TEMPLATES,
        Traffic,
        day_windows,
        history_state,
    )

    params = TemporalParams(ModelConfig())
    traffic = Traffic.make(params.bins)
    day_ns = 86_400 * 10**9
    start = T0_NS // day_ns * day_ns - HISTORY_DAYS * day_ns
    rows = np.arange(TEMPLATES, dtype=np.int64)
    state = history_state(params, traffic, TEMPLATES, rows, start)
    delta = window_ns(params.config.window_s)
    week = round(7 * day_ns / delta)
    v, k = params.values, params.n_periods
    first = start // delta
    span = HISTORY_DAYS * round(day_ns / delta)
    by_window = np.zeros((TEMPLATES * v, span))
    for day in range(HISTORY_DAYS):  # the days history_state learned, with its seeds
        w = day_windows(params, traffic, rows, day, 1, 1000 + day, start)
        pair, value = np.nonzero(w.cnt_values)
        flat = w.cnt_entry[pair] * v + value
        at = w.windows[w.cnt_slot[pair]] - first
        np.add.at(by_window, (flat, at), w.cnt_values[pair, value])
    windows = first + np.arange(span)
    phasor = np.exp(1j * np.multiply.outer(params.model_seconds(window_centre_ns(windows, delta)),
                                           params.omega))
    fold = np.zeros((span, week))  # the same counts by slot of the week
    fold[np.arange(span), windows % week] = 1.0
    by_slot = by_window @ fold
    stored = state.cnt_fourier[:TEMPLATES].reshape(-1, k)
    scale = np.maximum(by_window.sum(axis=1), 1.0)[:, None]
    slots = np.count_nonzero(by_slot, axis=1)
    counted = np.count_nonzero(by_window, axis=1)
    in_week = phasor[(np.arange(week) - first) % week]  # each slot's window in the first week
    return {
        "templates": TEMPLATES,
        "pairs": int(by_window.shape[0]),
        "pairs_counted": int(np.count_nonzero(counted)),
        "median_slots_per_pair": float(np.median(slots)),
        "most_slots_per_pair": int(slots.max()),
        "cnt_fourier_bytes_per_entry": 16 * k * v,
        "slot_histogram_bytes_per_entry": histogram_bytes(slots, k) / TEMPLATES,
        "slot_histogram_largest_relative_difference": float(
            np.max(np.abs(by_slot @ in_week - stored) / scale)
        ),
        "window_list_bytes_per_entry": histogram_bytes(counted, k, WINDOW_BYTES) / TEMPLATES,
        "window_list_largest_relative_difference": float(
            np.max(np.abs(by_window @ phasor - stored) / scale)
        ),
    }


def _default_maps(work: Path) -> list[Path]:
    """The benchmark map (10^4 entries), ``samples/office.mcap``'s and Lincoln's."""
    from aion_cli.api_make import build
    from benchmarks.bench_build_scale import write_query_map

    maps = [work / "bench_1e4.aion", work / "office.aion"]
    write_query_map(10**4, maps[0])
    build([Path(__file__).resolve().parents[1] / "samples" / "office.mcap"], maps[1])
    shared = os.environ.get("AION_SHARED_DATA")
    if shared and (Path(shared) / "lincoln").is_dir():
        from aion_cli.engine.config import ModelConfig
        from aion_cli.evaluation import lincoln

        days = lincoln.load_days(Path(shared) / "lincoln")
        train = [days[d] for d in sorted(set(lincoln.TRAIN_DAYS))]
        lincoln._build_aion(train, ModelConfig(timezone=lincoln.ZONE), work)
        maps.append(work / "lincoln.aion")
    return maps


def main(argv: list[str]) -> None:
    with tempfile.TemporaryDirectory(prefix="aion-layout-") as tmp:
        maps = [Path(a) for a in argv] or _default_maps(Path(tmp))
        out = [layout_figures(p) for p in maps]
        if not argv:
            out.append(template_slot_histograms())
        print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main(sys.argv[1:])
