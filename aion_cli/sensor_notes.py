"""What a map's manifest says of its fixed sensor, for the forecast notes
(:mod:`aion_cli.forecast_notes`): the share of its logs' own time it observed, and the note
for a sensor that observed less than half of it (a tracker silent when nobody is there makes
every forecast run high)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from aion_cli.manifest import Manifest


def sensor_share(manifest: Manifest) -> float | None:
    """The share of its logs' own time a fixed sensor observed (None: not a fixed sensor, or
    one whose recording spans ``build --observed`` declared: what it observed is then what it
    recorded, and build gives no advice for it either)."""
    from aion_cli.fixed_sensor import DECLARED, fixed_sensor_share

    if DECLARED in manifest.observation:
        return None
    return fixed_sensor_share(manifest.observation, recording_windows(manifest))


def recording_windows(manifest: Manifest) -> int | None:
    """How many windows the map's logs' own time spans (None: none recorded, or a damaged
    manifest's count)."""
    recording = manifest.counts.get("recording_windows")
    return recording if type(recording) is int and recording > 0 else None


def silent_sensor(manifest: Manifest) -> str | None:
    """The note for a fixed sensor that observed less than half of its logs' own time: if its
    tracker is silent when nobody is there, the windows observed are those with someone in
    them, and every forecast runs high (its nights and quiet hours most); None otherwise."""
    from aion_cli.fixed_sensor import SILENT_HINT, share_text, silent_advice

    share = sensor_share(manifest)
    if share is None or share >= 0.5:
        return None
    text = (
        f"the map's fixed sensor observed {share_text(share)} of its logs' time (only the "
        "windows in which a log recorded a message; the rest is unknown, not empty): "
    )
    advice = silent_advice(manifest.counts)
    if advice != SILENT_HINT:  # its tracker published messages with nobody in them
        return text + advice
    return text + (
        "if its tracker is silent when nobody is there, the windows observed are those with "
        "someone in them and the forecast runs high, most in quiet hours: declare the spans it "
        "was recording with aion build --observed"
    )
