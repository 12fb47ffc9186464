"""TOML mappings of a custom message without a header (``my_tracker/msg/Blobs`` on
/blobs, each blob with its own time, frame and velocity as two numbers) from the command
line: built, refused when the mapping is bad, and suggested by ``--suggest-mapping``.

Split from tests/cli/test_detections_mapping.py (the Person bag, the README's examples)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import assert_one_line_error, map_cells, run, run_json
from tests.cli.own_definitions import Message, OwnTypes, write_mcap

S = 1_000_000_000
T0 = 1_700_000_400 * S  # aligned to 600-s windows


BLOBS = "my_tracker/msg/Blobs"
BLOB_TYPES = {
    "my_tracker/msg/Blob": "int64 t_ns\nstring frame\nuint32 id\nfloat64 x\nfloat64 y\n"
    "float64 vx\nfloat64 vy\n",
    BLOBS: "my_tracker/Blob[] blobs\n",
}
BLOB_MAPPING = """\
[[topic]]
topic = "/blobs"
msgtype = "my_tracker/msg/Blobs"
array = "blobs"
position = ["x", "y"]
velocity = ["vx", "vy"]
id = "id"
item_stamp = "t_ns"
item_frame = "frame"
"""


def blob_log(path: Path) -> Path:
    """``my_tracker/msg/Blobs`` on /blobs: no header, each blob with its own time (int64
    nanoseconds), frame and velocity as two numbers. Ten messages a second apart, logged at
    T0 + k s; each blob's time 1 ms later (what the decoder reads: tests/formats), its frame
    base_laser.
    Blob 1 walks -x (velocity (-1, 0): heading pi, bin 0), blob 2 +y (velocity (0, 0.5):
    heading pi/2, bin 6)."""
    own = OwnTypes(BLOB_TYPES)
    blob = own.T["my_tracker/msg/Blob"]
    msgs = []
    for k in range(10):
        t = T0 + k * S
        items = [
            blob(t_ns=t + 10**6, frame="base_laser", id=1, x=20.0 - k, y=3.0, vx=-1.0, vy=0.0),
            blob(t_ns=t + 10**6, frame="base_laser", id=2, x=2.0, y=0.5 * k, vx=0.0, vy=0.5),
        ]
        msgs.append(Message("/blobs", BLOBS, own.cdr(own.T[BLOBS](blobs=items), BLOBS), t))
    return write_mcap(path, msgs, {BLOBS: own.definition(BLOBS)})


def test_a_velocity_of_two_numbers_and_per_item_times_without_a_header(tmp_path: Path) -> None:
    """``velocity = ["vx", "vy"]`` was refused ("'velocity' must be a string") and an element's
    own time and frame could only be read from a header (``item_header``); ``item_stamp`` and
    ``item_frame`` now read them from any fields of the element (without item_frame the
    mapping is refused: the type has no header, so no frame)."""
    log = blob_log(tmp_path / "blobs.mcap")
    mapping = tmp_path / "blobs.toml"
    mapping.write_text(BLOB_MAPPING)
    out = tmp_path / "blobs.aion"
    report = run_json("build", log, "-o", out, "--detections-mapping", mapping,
                      "--map-frame", "base_laser", "--format", "json")  # fmt: skip
    assert report["detections"] == {"read": 20, "used": 20, "dropped": {}}
    assert report["headings"]["velocity"] == 20  # every one from its two numbers
    assert report["detection_decoding"]["/blobs"]["decoder"] == "mapping"
    _, counts, nodir = map_cells(out)
    assert counts.sum(axis=0).tolist() == [10, 0, 0, 0, 0, 0, 10, 0]
    assert nodir.sum() == 0


@pytest.mark.parametrize(
    ("change", "fragments"),
    [
        (('velocity = ["vx", "vy"]', 'velocity = ["vx"]'),
         ("'velocity' as a list names 2 or 3 number fields", "['vx']")),
        (('velocity = ["vx", "vy"]', 'velocity = ["vx", "speed"]'),
         ("velocity path 'speed'", "has no field 'speed'")),
        (('velocity = ["vx", "vy"]', 'velocity = ["vx", "frame"]'),
         ("velocity path 'frame' must lead to a number",)),
        (('item_stamp = "t_ns"', 'item_stamp = "frame"'),
         ("item_stamp path 'frame' must lead to a time stamp",)),
        (('item_frame = "frame"', 'item_frame = "id"'),
         ("item_frame path 'id' must lead to a frame name",)),
        (('item_frame = "frame"', ""), ("has no header", "frame of its positions")),
        (('item_stamp = "t_ns"', 'item_stamp = "t_ns"\nitem_header = "h"'),
         ("give 'item_header'", "'item_stamp'")),
    ],
)
def test_bad_blob_mappings_name_the_key(
    tmp_path: Path, change: tuple[str, str], fragments: tuple[str, ...]
) -> None:
    log = blob_log(tmp_path / "blobs.mcap")
    assert change[0] in BLOB_MAPPING
    mapping = tmp_path / "bad.toml"
    mapping.write_text(BLOB_MAPPING.replace(*change))
    result = run("build", log, "-o", tmp_path / "x.aion", "--detections-mapping", mapping,
                 "--map-frame", "base_laser")  # fmt: skip
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, *fragments)


def test_suggest_mapping_proposes_velocity_numbers_and_the_items_own_time_and_frame(
    tmp_path: Path,
) -> None:
    """--suggest-mapping of the blob type never proposed ``velocity = ["vx", "vy"]``,
    ``item_stamp`` or ``item_frame`` (it said "velocity: no candidate" and asked for a
    frame_override, so the blobs were placed at their messages' log times in a guessed frame,
    their headings from linking). It proposes the hand-written mapping's lines now, and the
    suggestion builds the map that mapping builds."""
    import tomllib

    log = blob_log(tmp_path / "blobs.mcap")
    suggested = run("info", log, "--suggest-mapping", "/blobs")
    assert suggested.exit_code == 0, suggested.stderr
    (topic,) = tomllib.loads(suggested.stdout)["topic"]
    (wanted,) = tomllib.loads(BLOB_MAPPING)["topic"]
    assert topic == wanted  # no frame_override: item_frame gives each blob's
    mapping = tmp_path / "suggested.toml"
    mapping.write_text(suggested.stdout)
    out = tmp_path / "suggested.aion"
    report = run_json("build", log, "-o", out, "--detections-mapping", mapping,
                      "--map-frame", "base_laser", "--format", "json")  # fmt: skip
    assert report["headings"]["velocity"] == 20
    _, counts, _ = map_cells(out)
    assert counts.sum(axis=0).tolist() == [10, 0, 0, 0, 0, 0, 10, 0]
