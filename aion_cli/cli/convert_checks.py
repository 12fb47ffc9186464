"""``aion convert``'s checks of its input, output and options, made before anything is read
or written: which container the output gets, whether the options fit the layout, and
whether TRACKS is a tracks file at all (not a folder, a log, a map or a scene graph)."""

from __future__ import annotations

from pathlib import Path

#: layouts with frame numbers, and their frame rate when --fps is not given
FRAME_LAYOUTS = {"eth": 25.0, "ucy": 25.0, "edinburgh": 9.0}
#: layouts whose times are absolute already (--start is refused), and what their times are
ABSOLUTE_TIMES = {
    "canonical": "its t_ns column is nanoseconds since 1970 (UTC)",
    "lincoln": "Lincoln times are UNIX seconds",
    "atc": "ATC times are UNIX seconds",
}
#: layouts whose times count from the recording's start: --start says when that was
RELATIVE_LAYOUTS = ("thor", "thor-magni", "eth", "ucy")


def check_tracks_input(tracks: Path) -> None:
    """:class:`InputError` when ``tracks`` is no tracks file: missing, a folder (a rosbag2
    log, or a folder of files), a log, an aion map or a saved scene graph, each named with
    where it goes. (A folder was "tracks file not found: data" and a scene graph "the file looks
    cut short".)"""
    from aion_cli.errors import InputError, path_word
    from aion_cli.formats.input_kind import input_kind
    from aion_cli.formats.raw import check_regular_input

    # a FIFO or device (/dev/null) was "tracks file not found": it exists, and reading one
    # can block forever or never end
    check_regular_input(tracks, "tracks file", InputError, hint="give a tracks file (CSV or text)")
    word = path_word(tracks)  # the path in a command to paste
    if tracks.is_dir():
        if (tracks / "metadata.yaml").is_file():
            raise InputError(
                f"{tracks} is a rosbag2 log, not a tracks file",
                hint=f"build a map from it: aion build {word} -o MAP.aion",
            )
        raise InputError(
            f"{tracks} is a folder, not a tracks file",
            hint="aion convert reads one tracks file (CSV or text): give a file in it",
        )
    if not tracks.is_file():
        raise InputError(f"tracks file not found: {tracks}", hint="check the path")
    kind = input_kind(tracks)
    if kind == "log":
        raise InputError(
            f"{tracks.name} is a log, not a tracks file",
            hint=f"build a map from it: aion build {word} -o MAP.aion",
        )
    if kind == "map":
        raise InputError(
            f"{tracks.name} is an aion map, not a tracks file",
            hint=f"query it: aion predict {word}",
        )
    if kind == "graph":
        raise InputError(
            f"{tracks.name} is a scene graph, not a tracks file",
            hint=f"publish it with the tracks: aion convert TRACKS --graph {word} -o LOG",
        )


def container_for(output: Path, container: str | None) -> str:
    """``--container``, else from the suffix: .bag -> ROS 1 bag, .mcap -> ROS 2 MCAP,
    no suffix -> a rosbag2 folder (sqlite3)."""
    suffix = output.suffix.lower()
    if container is not None:
        _check_suffix(output, suffix, container)
        return container
    if suffix == ".bag":
        return "bag"
    if suffix == ".mcap":
        return "mcap"
    if suffix == "":
        return "rosbag2-sqlite3"
    from aion_cli.errors import InputError

    raise InputError(
        f"cannot tell the log format from {output.name!r}",
        hint="name it .mcap or .bag, or give --container",
    )


#: the containers a file of each suffix may hold: ``aion`` and other tools read a file's
#: format from its suffix, so an MCAP named .bag could not be read back as written
_SUFFIX_CONTAINERS = {".mcap": ("mcap", "mcap-ros1"), ".bag": ("bag",)}


def _check_suffix(output: Path, suffix: str, container: str) -> None:
    """:class:`InputError` when ``--container`` contradicts the output's suffix (``x.mcap``
    written as a ROS 1 bag)."""
    from aion_cli.errors import InputError

    allowed = _SUFFIX_CONTAINERS.get(suffix)
    if allowed is not None and container not in allowed:
        raise InputError(
            f"--container {container} does not match the output name {output.name!r}",
            hint=f"name the output for its container, or give --container {allowed[0]}",
        )


def check_start_applies(tracks: Path, layout: str) -> None:
    """``--start`` where the file and the layout disagree on whether its times count from 0,
    refused before anything is written: an ATC file given as ``--layout thor`` would be moved
    decades on, and a THÖR file given as ``--layout atc`` needs ``--layout thor``."""
    from aion_cli.errors import InputError
    from aion_cli.formats.track_sniff import guess_layout

    guess = guess_layout(tracks)
    if guess is None or layout in guess.layouts:
        return
    if guess.layout in ABSOLUTE_TIMES and layout in RELATIVE_LAYOUTS:
        raise InputError(
            f"--start would shift {tracks.name}'s times, but they are UNIX seconds already: "
            f"it looks like {guess.describe()}",
            hint=f"convert it with --layout {guess.layout} and without --start",
        )
    if guess.layout == "thor" and layout == "atc":  # the same columns, another clock
        raise InputError(
            f"{tracks.name}'s times count from 0, which --layout {layout} reads as absolute: it "
            f"looks like {guess.describe()}",
            hint=f"convert it with --layout {guess.layout} --start T",
        )


def check_layout_options(
    layout: str,
    date_text: str | None,
    start_text: str | None,
    fps: float | None,
    length_unit: str | None,
) -> None:
    """The options that apply to ``layout`` only, checked before anything is read."""
    from aion_cli.errors import InputError

    if layout in ABSOLUTE_TIMES and start_text is not None:
        raise InputError(
            f"--start does not apply to the {layout} layout",
            hint=f"{ABSOLUTE_TIMES[layout]} already; drop --start",
        )
    if layout == "edinburgh":
        if start_text is not None:
            raise InputError(
                "--start does not apply to the edinburgh layout: give --date",
                hint='--date DAY puts frame 0 at midnight, --date "DAY HH:MM" at that time',
            )
        if date_text is None:
            raise InputError(
                "the edinburgh layout needs --date: its files have frame numbers, no clock",
                hint="e.g. --date 2010-07-01 --tz Europe/London for tracks.01Jul.txt (the "
                "database recorded Aug 2009 - Jan 2010 and May - Aug 2010)",
            )
    elif date_text is not None:
        raise InputError(
            f"--date applies to the edinburgh layout only, not {layout}",
            hint="thor, thor-magni, eth and ucy times count from --start; atc, lincoln and "
            "canonical times are absolute",
        )
    if fps is not None:
        if layout not in FRAME_LAYOUTS:
            raise InputError(
                f"--fps does not apply to the {layout} layout",
                hint=f"only {', '.join(FRAME_LAYOUTS)} files have frame numbers",
            )
        if not 0 < fps <= 10_000:  # also NaN and inf: frames of no duration
            raise InputError(
                f"--fps must be above 0 and at most 10,000 frames per second, not {fps}",
                hint="e.g. --fps 25 (ETH / UCY frame numbers), --fps 9 (Edinburgh)",
            )
    if length_unit is not None and layout != "thor-magni":
        raise InputError(
            f"--length-unit does not apply to the {layout} layout",
            hint="only thor-magni files may be in millimetres",
        )
