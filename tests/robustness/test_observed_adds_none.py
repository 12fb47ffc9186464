"""``--observed`` spans whose every window within the logs' time already holds a message add
no window: the build says so in words, as it did not (stop 67's audit: two ATC hours converted
with ``--observed``, whose marker messages fill every window, built with "--observed: 0
window(s) without a message taken as observed (0 s), the time between the logs included").
A span that does add windows keeps its count."""

from __future__ import annotations

from pathlib import Path

from tests.robustness.conftest import T0, S, build_json, walk, write_log

N = 1200  # one a second from T0 (a window start): 08:00-08:20, two windows full


def _observed_notes(report: dict) -> list[str]:
    """The notes of the windows the spans added (not: a parallel build's of its sequence)."""
    return [
        n for n in report["notes"]
        if n.startswith("--observed: ") and ("taken as observed" in n or "add none" in n)
    ]


def test_spans_over_windows_with_messages_are_said_to_add_none(tmp_path: Path) -> None:
    log = write_log(tmp_path / "walk.mcap", walk(N))
    start = T0 // S
    for workers in ("1", "2"):
        within = build_json(log, "--observed", f"{start}..{start + N}", "--workers", workers,
                            "-o", tmp_path / f"w{workers}.aion")  # fmt: skip
        assert _observed_notes(within) == [
            "--observed: every window the spans declare within the logs' time holds a message "
            "already: they add none"
        ]
    later = write_log(tmp_path / "later.mcap", walk(60, start_s=3 * 600))  # 08:30-08:31
    both = build_json(log, later, "--observed", f"{start}..{start + 4 * 600}",
                      "-o", tmp_path / "b.aion")  # fmt: skip
    assert _observed_notes(both) == [
        "--observed: 1 window(s) without a message taken as observed (10 min), the time "
        "between the logs included"
    ]
