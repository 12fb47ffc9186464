"""``benchmarks.bench_map_layout``: the figures behind docs/BENCHMARKS.md's stop-67 section on
the Fourier sums' layout (issue 15's map size) measure what they say."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.slow


def test_histogram_bytes_keep_the_sums_where_they_are_smaller() -> None:
    from benchmarks.bench_map_layout import histogram_bytes

    # 4 bytes of offset, then 4 per slot, at most the 31 complex sums' 496 bytes
    assert histogram_bytes(np.array([0, 1, 200]), 31) == 4 + 8 + 496
    assert histogram_bytes(np.array([2]), 31, per_slot=6) == 4 + 12


def test_the_benchmark_maps_pairs_all_count_and_repeat_its_templates(tmp_path: Path) -> None:
    """``bench_engine.build_state`` tiles 64 templates of 9 value bins over every entry, and
    each template counts detections in every bin over its two weeks: no pair is left out,
    and all but 64 x 9 stored rows repeat one of the templates'."""
    from benchmarks.bench_build_scale import write_query_map
    from benchmarks.bench_map_layout import layout_figures
    from benchmarks.bench_temporal import TEMPLATES

    path = tmp_path / "bench.aion"
    write_query_map(1000, path)
    figures = layout_figures(path)
    assert figures["pairs_stored"] == figures["pairs"] == figures["entries"] * 9
    assert figures["pairs_never_counted"] == 0.0
    assert figures["stored_rows_all_zero"] == 0
    assert figures["duplicate_cnt_rows"] == pytest.approx(
        1 - TEMPLATES * 9 / figures["pairs_stored"], abs=1e-12
    )
    assert figures["cnt_fourier_bytes_per_entry"] == 9 * 31 * 16


def test_window_lists_give_the_sums_back_and_week_slots_do_not() -> None:
    """The templates' sums recomputed from their windows' counts are the accumulated ones to
    rounding; from the counts per slot of the week they drift (the periods are rounded to
    10^-6 s, so a week is not a whole number of each), beyond the 1e-9 a layout may move."""
    from benchmarks.bench_map_layout import template_slot_histograms

    figures = template_slot_histograms()
    assert figures["pairs_counted"] == figures["pairs"] == 64 * 9
    assert figures["window_list_largest_relative_difference"] < 1e-12
    assert figures["slot_histogram_largest_relative_difference"] > 1e-9
    assert figures["window_list_bytes_per_entry"] < figures["cnt_fourier_bytes_per_entry"]


def test_a_deflated_copy_reads_as_the_map(tmp_path: Path) -> None:
    """The copy :func:`deflated_copy` writes holds the same arrays, its zero-heavy members
    deflated (smaller) and its noise-like Fourier sums stored, and aion reads it."""
    import zipfile

    from aion_cli.formats.mapfile import read_map
    from benchmarks.bench_build_scale import write_query_map
    from benchmarks.bench_map_layout import deflated_copy

    path, copy = tmp_path / "bench.aion", tmp_path / "deflated.aion"
    write_query_map(1000, path)
    before, after = deflated_copy(path, copy)
    assert after < before
    with zipfile.ZipFile(copy) as zf:
        kinds = {i.filename: i.compress_type for i in zf.infolist()}
    assert kinds["temporal_cnt_fourier.npy"] == zipfile.ZIP_STORED
    assert kinds["entry_window_counts.npy"] == zipfile.ZIP_DEFLATED  # zeros but the open window
    ours, theirs = read_map(path)[0], read_map(copy)[0]
    assert set(ours) == set(theirs)
    for name in ours:
        np.testing.assert_array_equal(ours[name], theirs[name], err_msg=name)
