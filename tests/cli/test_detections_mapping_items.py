"""``--detections-mapping`` on items a mapping cannot read whole (split from
``test_detections_mapping.py``): a definition naming a type it does not define, an item whose
sequence is too short (dropped, not the build), every item too short, and a missing or broken
mapping file, each with its one-line error or hint."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.cli.conftest import assert_one_line_error, map_cells, run, run_json
from tests.cli.own_definitions import Message, OwnTypes, write_mcap
from tests.cli.test_detections_mapping import person_bag

S = 1_000_000_000
T0 = 1_700_000_400 * S  # aligned to 600-s windows


def _ros1_tracks_mcap(path: Path, velocity_type: str) -> Path:
    """An MCAP (ROS 1 profile) of ``trk/Tracks`` whose ros1msg schema is written by hand:
    two tracks (float32 x, y) per message, 30 messages at 2 Hz in frame map, the velocity a
    ``velocity_type``."""
    import struct

    from mcap.writer import Writer

    sep = "=" * 80
    schema = (
        f"Header header\nTrack[] tracks\n{sep}\nMSG: std_msgs/Header\nuint32 seq\ntime stamp\n"
        f"string frame_id\n{sep}\nMSG: trk/Track\nuint32 id\nfloat32 x\nfloat32 y\n"
        f"{velocity_type} velocity\n{sep}\nMSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\n"
        "float64 z\n"
    )
    with path.open("wb") as f:
        w = Writer(f)
        w.start(profile="ros1", library="aion tests")
        channel = w.register_channel(
            "/tracks", "ros1", w.register_schema("trk/Tracks", "ros1msg", schema.encode())
        )
        for k in range(30):
            t = T0 + k * S // 2
            data = struct.pack("<IIII", k, *divmod(t, S), 3) + b"map" + struct.pack("<I", 2)
            for i, x, vx in ((1, 0.5 * k, 1.0), (2, 20 - 0.5 * k, -1.0)):
                data += struct.pack("<Iffddd", i, x, 2.0 * i, vx, 0.0, 0.0)
            w.add_message(channel, t, data, t, sequence=k)
        w.finish()
    return path


def test_a_definition_using_a_type_it_does_not_define_is_named(tmp_path: Path) -> None:
    """A ros1msg schema that writes ``Point velocity`` in package trk (ROS 1 reads it as
    trk/Point, which no MSG: block defines) made ``aion info`` fail as an internal error
    (KeyError: 'trk/msg/Point') and the build call every message corrupt. Now info lists
    the topic, --suggest-mapping and build say which type is missing (exit 2); with
    ``geometry_msgs/Point`` the same log builds its 60 detections."""
    bad = _ros1_tracks_mcap(tmp_path / "bad.mcap", "Point")
    info = run("info", bad)
    assert info.exit_code == 0, info.stderr
    assert "internal error" not in info.stderr
    assert "/tracks" in info.stdout
    missing = ("the log's definition of trk/msg/Tracks uses trk/msg/Point, which it does not "
               "define",)  # fmt: skip
    suggested = run("info", bad, "--suggest-mapping", "/tracks")
    assert suggested.exit_code == 2
    assert_one_line_error(suggested.stderr, *missing)
    assert "hint: its embedded definition lacks the MSG: block" in suggested.stderr
    mapping = tmp_path / "tracks.toml"
    mapping.write_text('[[topic]]\ntopic = "/tracks"\nmsgtype = "trk/msg/Tracks"\n'
                       'array = "tracks"\nposition = ["x", "y"]\nid = "id"\n')  # fmt: skip
    built = run("build", bad, "-o", tmp_path / "bad.aion", "--detections-mapping", mapping)
    assert built.exit_code == 2
    assert_one_line_error(built.stderr, *missing)
    good = _ros1_tracks_mcap(tmp_path / "good.mcap", "geometry_msgs/Point")
    report = run_json("build", good, "-o", tmp_path / "good.aion", "--detections-mapping",
                      mapping, "--format", "json")  # fmt: skip
    assert report["detections"] == {"read": 60, "used": 60, "dropped": {}}
    assert report["mean_speed_m_s"] == pytest.approx(1.0)


def _short_log(tmp_path: Path, short: set[tuple[int, str]]) -> tuple[Path, Path]:
    """``fx/Ps``: people with ``float64[] pos``, mapped as ``pos[0..1]``, and the mapping.
    Person a walks +x and b -x at 0.5 m/s, one message a second for 20 s; the (second,
    name) items in ``short`` have an empty ``pos``."""
    types = {"fx/msg/P": "string name\nfloat64[] pos\n",
             "fx/msg/Ps": "std_msgs/Header header\nfx/P[] people\n"}  # fmt: skip
    own = OwnTypes(types)
    T = own.T
    messages = []
    for k in range(20):
        t = T0 + k * S
        at = {"a": [0.5 * k, 1.0], "b": [10.0 - 0.5 * k, 4.0]}
        people = [T["fx/msg/P"](name=n, pos=np.array([] if (k, n) in short else xy))
                  for n, xy in at.items()]  # fmt: skip
        msg = T["fx/msg/Ps"](header=own.header(t, "map"), people=people)
        messages.append(Message("/people", "fx/msg/Ps", own.cdr(msg, "fx/msg/Ps"), t))
    log = write_mcap(tmp_path / "short.mcap", messages,
                     {"fx/msg/Ps": own.definition("fx/msg/Ps")})  # fmt: skip
    mapping = tmp_path / "short.toml"
    mapping.write_text('[[topic]]\ntopic = "/people"\nmsgtype = "fx/msg/Ps"\n'
                       'array = "people"\nposition = "pos[0..1]"\nid = "name"\n')  # fmt: skip
    return log, mapping


def test_an_item_whose_sequence_is_too_short_is_dropped_not_the_build(tmp_path: Path) -> None:
    """In message 7 b's ``pos`` is empty (:func:`_short_log`). That one item stopped the
    build ('error: field path 'pos[0..1]': index 1 out of range'); now it is dropped and
    counted (``short_array``) and the other 39 detections build."""
    log, mapping = _short_log(tmp_path, {(7, "b")})
    report = run_json("build", log, "-o", tmp_path / "short.aion", "--detections-mapping",
                      mapping, "--format", "json")  # fmt: skip
    assert report["detections"] == {"read": 40, "used": 39, "dropped": {"short_array": 1}}
    assert report["mean_speed_m_s"] == pytest.approx(0.5)
    _, counts, _ = map_cells(tmp_path / "short.aion")
    assert counts.sum(axis=0).tolist() == [18, 0, 0, 0, 19, 0, 0, 0]  # b -x (bin 0), a +x


def test_a_missing_or_broken_mapping_file_comes_with_a_hint(tmp_path: Path) -> None:
    """A mapping file that cannot be read, or is not TOML, was an error line with no hint
    (every other bad input says what to do): now the hint points to --suggest-mapping."""
    log = person_bag(tmp_path / "legs.bag")
    broken = tmp_path / "broken.toml"
    broken.write_text('[[topic]]\ntopic "/people"\n')  # the '=' left out
    for mapping, fragment in ((tmp_path / "absent.toml", "cannot read mapping file"),
                              (broken, "broken.toml is not valid TOML")):
        for args in (("info", log), ("build", log, "-o", tmp_path / "x.aion")):
            result = run(*args, "--detections-mapping", mapping)
            assert result.exit_code == 2, result.stderr
            assert_one_line_error(result.stderr, fragment)
            hints = [line for line in result.stderr.splitlines() if line.startswith("hint: ")]
            assert len(hints) == 1, result.stderr
            assert "--suggest-mapping" in hints[0]


def test_a_build_whose_every_item_is_too_short_says_so(tmp_path: Path) -> None:
    """Every ``pos`` empty: the hint said "the topics carry no detections", but the 40 items
    are there, their arrays shorter than the mapping's ``pos[0..1]``; it says so, no map."""
    log, mapping = _short_log(tmp_path, {(k, n) for k in range(20) for n in "ab"})
    out = tmp_path / "short.aion"
    result = run("build", log, "-o", out, "--detections-mapping", mapping)
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, "no people detection in the 20 messages of /people",
                          "(dropped: short_array 40)")  # fmt: skip
    assert "carry no detections" not in result.stderr
    assert "hint: the topics carry 40 items, but each one's array is shorter than an index " \
        "in the --detections-mapping's paths" in result.stderr  # fmt: skip
    assert "--suggest-mapping /people" in result.stderr
    assert "no map was written" in result.stderr
    assert not out.exists()
