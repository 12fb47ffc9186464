"""Which windows a robot's map counts as observed, against the truth of the trajectory the
log was written from (issue 12): never time the robot was unlocalised."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from aion_cli.build_observation import silent_note
from aion_cli.mapquery import load_map
from aion_cli.pipeline import BuildOptions, build_map

S = 1_000_000_000
WINDOW = 600
T0 = 1_767_571_200  # 2026-01-05 00:00 UTC, a window boundary
SPOTS = {"A": (2.25, 0.25), "B": (20.25, 0.25), "C": (38.25, 0.25)}
RANGE = 8.0
LOST = (1800, 3630)  # no map->odom: localisation lost (resumes inside window 6)


def _stamp(t_ns: int) -> dict[str, int]:
    return {"sec": t_ns // S, "nanosec": t_ns % S}


def _tf(t_ns: int, parent: str, child: str, x: float) -> dict[str, Any]:
    return {
        "transforms": [
            {
                "header": {"stamp": _stamp(t_ns), "frame_id": parent},
                "child_frame_id": child,
                "transform": {"translation": {"x": x, "y": 0.0, "z": 0.0}, "rotation": {"w": 1.0}},
            }
        ]
    }


def _robot_x(t: int) -> float:
    """Back and forth between x = 0 and x = 40 every 20 minutes."""
    phase = (t % 1200) / 1200
    return 80 * phase if phase < 0.5 else 80 * (1 - phase)


def _write(
    path: Path, seconds: int, lost: tuple[int, int] = LOST, crash: tuple[int, int] = (0, 0)
) -> dict[str, set[int]]:
    """The log (map->odom at 1 Hz but while ``lost``, odom->base_link at 5 Hz, people seen
    from base_link every second but while the tracker is down, ``crash``) and the truth: per
    spot, the windows from its first detection on in which the localised robot came within
    RANGE of it."""
    from aion_cli.formats.writers import LogWriter

    truth: dict[str, set[int]] = {}
    first: dict[str, int] = {}
    with LogWriter(path, "mcap") as writer:
        for t in range(seconds):
            t_ns = (T0 + t) * S
            x, drift = _robot_x(t), 0.01 * t
            localised = not lost[0] <= t < lost[1]
            if localised:
                writer.write("/tf", "tf2_msgs/msg/TFMessage", _tf(t_ns, "map", "odom", drift), t_ns)
            for k in range(5):
                tk = t_ns + k * S // 5
                msg = _tf(tk, "odom", "base_link", x - drift)
                writer.write("/tf", "tf2_msgs/msg/TFMessage", msg, tk)
            tracks = []
            for i, (name, (sx, sy)) in enumerate(SPOTS.items()):
                if np.hypot(sx - x, sy) <= RANGE:
                    first.setdefault(name, (T0 + t) // WINDOW)
                    if localised:
                        truth.setdefault(name, set()).add((T0 + t) // WINDOW)
                    pose = {"position": {"x": sx - x, "y": sy, "z": 0.0}, "orientation": {"w": 1.0}}
                    tracks.append({"track_id": i, "is_matched": True, "pose": {"pose": pose}})
            if crash[0] <= t < crash[1]:
                continue
            det_ns = t_ns + S // 2
            header = {"stamp": _stamp(det_ns), "frame_id": "base_link"}
            people = {"header": header, "tracks": tracks}
            writer.write("/tracks", "spencer_tracking_msgs/msg/TrackedPersons", people, det_ns)
    return {n: {w for w in ws if w >= first[n]} for n, ws in truth.items()}


def _observed_windows(path: Path) -> dict[str, set[int]]:
    """Per spot, the windows the built map counts as observed for the entry at it (a map of
    one local day: every window still in its pending day, or its open window)."""
    state = load_map(path, writable=True).state
    ent, day = state.entries, state.pending.consolidated()
    assert not state.temporal.obs.n.any()  # nothing absorbed yet: the day is whole below
    out: dict[str, set[int]] = {}
    for name, spot in SPOTS.items():
        rows = ent.live_rows()
        row = rows[np.argmin(np.hypot(*(ent.xyz[rows, :2] - spot).T))]
        assert np.hypot(*(ent.xyz[row, :2] - spot)) < 0.5
        windows = {int(day.windows[s]) for s in day.obs_slot[day.obs_entry == row]}
        window = state.open_window
        if window is not None and (
            state.observation.observed(ent.xyz[[row], :2], window, WINDOW * S, RANGE)[0]
            or ent.window_counts[row].any()
        ):
            windows.add(int(window))
        out[name] = windows
    return out


def test_lost_localisation_is_not_observed(tmp_path: Path) -> None:
    """map->odom silent for half an hour while odom->base_link goes on: the robot's pose in
    the map is unknown then, so no window of it counts as observed (it was interpolated
    across the gap: every pass in it counted, its detections placed where the robot was not)."""
    log = tmp_path / "lost.mcap"
    truth = _write(log, 5400)
    out = tmp_path / "lost.aion"
    build_map(BuildOptions(logs=(log,), output=out))
    got = _observed_windows(out)
    assert got == truth
    lost = set(range((T0 + LOST[0]) // WINDOW, (T0 + LOST[1]) // WINDOW))
    assert not lost & set().union(*got.values())


def test_a_silent_tracker_on_a_moving_robot_is_noted(tmp_path: Path) -> None:
    """The tracker publishes nothing for an hour while the robot drives on: its poses count
    those windows as observed and empty, which the build cannot tell from an empty corridor;
    it says how many there are (all six of the hour; with two workers the log is cut into
    time shards inside that hour, and their counts add up into the one note)."""
    log = tmp_path / "crash.mcap"
    crash = (3600, 7200)
    _write(log, 3 * 3600, lost=(0, 0), crash=crash)
    windows = (crash[1] - crash[0]) // WINDOW  # the robot moves on throughout
    for workers in (1, 2):
        out = tmp_path / f"crash{workers}.aion"
        report = build_map(BuildOptions(logs=(log,), output=out, workers=workers))
        assert (len(report.workers) > 1) == (workers > 1)  # cut into shards, or not
        silent = [n for n in report.notes if n.startswith("robot trajectory: ")]
        assert silent == [silent_note(windows, WINDOW * S)]
        assert report.silent_windows == (windows, WINDOW * S)
    quiet = tmp_path / "quiet.mcap"  # the same log with the tracker up throughout
    _write(quiet, 3 * 3600, lost=(0, 0))
    report = build_map(BuildOptions(logs=(quiet,), output=tmp_path / "quiet.aion"))
    assert not [n for n in report.notes if n.startswith("robot trajectory: ")]
    assert report.silent_windows == (0, WINDOW * S)
