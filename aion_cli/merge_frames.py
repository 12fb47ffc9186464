"""The map frames of maps merged by ``aion merge``: the one frame they all record, or the
warning for maps that record different ones (their positions are merged as if one)."""

from __future__ import annotations


def common_frame(frames: list[str | None]) -> str | None:
    """The map frame every input records (None when one records none or they differ)."""
    first = frames[0] if frames else None
    return first if first is not None and all(f == first for f in frames) else None


def frame_warning(frames: list[tuple[str, str | None]]) -> str | None:
    """The warning for maps that record different map frames (``right_laser`` and
    ``rear_laser``: their positions are merged as if one frame); None when they record one
    (maps that record none, written before the record, say nothing)."""
    known = [(name, f) for name, f in frames if f is not None]
    distinct = len({f for _, f in known})
    if distinct < 2:
        return None
    listed = ", ".join(f"{name}: {f!r}" for name, f in known)
    return (
        f"the maps hold positions in different frames ({listed}): they are merged as if "
        f"{'both' if distinct == 2 else f'all {distinct}'} were one frame, and the merged "
        "map records none; merge maps of one frame "
        "(aion info MAP --format json: map_frame)"
    )
