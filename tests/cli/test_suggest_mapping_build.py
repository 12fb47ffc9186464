"""The build command a suggested mapping names runs as written: ``aion info LOG
--suggest-mapping TOPIC`` prints a mapping whose comment says which ``aion build`` reads it.
For turtlesim's poses of rosbag.js' example bag (no header: ``frame_override = "world"``, the
TF root) that command stopped with "unknown frame 'map'": the bag's TF has no frame ``map``,
so the build needs ``--map-frame world``, which the comment now names."""

from __future__ import annotations

import shlex
from pathlib import Path

from tests.cli.conftest import run, run_json
from tests.cli.own_definitions import Message, OwnTypes, write_mcap
from tests.shared_data import real

TURTLE_POSE = "turtlesim/msg/Pose"


def suggested_build(text: str) -> list[str]:
    """The arguments after ``aion build`` on the suggestion's comment line that names it."""
    (line,) = [x for x in text.splitlines() if x.startswith("#   aion build ")]
    return shlex.split(line.removeprefix("#   aion build "))


def build_as_suggested(text: str, log: Path, folder: Path) -> tuple[Path, list[str]]:
    mapping = folder / "mapping.toml"
    mapping.write_text(text)
    words = suggested_build(text)
    args = [str(log) if w == "LOG" else str(mapping) if w == "THIS_FILE" else w for w in words]
    out = folder / "map.aion"
    built = run("build", *args, "-o", out)
    assert built.exit_code == 0, built.stderr
    return out, words


def test_the_suggested_build_reads_turtlesim_poses_in_the_tf_root(tmp_path: Path) -> None:
    from rosbags.highlevel import AnyReader

    bag = real("logs", "rosbagjs_fixtures", "example-bz2.bag")
    frames = set()
    with AnyReader([bag]) as reader:  # the bag's TF frames, read by rosbags
        tf = [c for c in reader.connections if c.topic in ("/tf", "/tf_static")]
        for conn, _, raw in reader.messages(connections=tf):
            for t in reader.deserialize(raw, conn.msgtype).transforms:
                frames |= {t.header.frame_id.lstrip("/"), t.child_frame_id.lstrip("/")}
        poses = sum(1 for c in reader.connections if c.topic == "/turtle1/pose"
                    for _ in reader.messages(connections=[c]))  # fmt: skip
    assert "map" not in frames
    assert "world" in frames
    text = run("info", bag, "--suggest-mapping", "/turtle1/pose").stdout
    assert 'frame_override = "world"' in text
    out, words = build_as_suggested(text, bag, tmp_path)
    assert words[-2:] == ["--map-frame", "world"]
    info = run_json("info", out, "--format", "json")
    assert info["map_frame"] == "world"
    assert info["counts"]["used"] == poses == 1344


def test_a_log_without_tf_keeps_the_plain_build_command(tmp_path: Path) -> None:
    """No TF: the positions are taken in ``map`` (the default), and the command stays plain."""
    own = OwnTypes({TURTLE_POSE: "float32 x\nfloat32 y\nfloat32 theta\n"})
    T0 = 1_700_000_400 * 10**9
    messages = [
        Message("/turtle1/pose", TURTLE_POSE,
                own.cdr(own.T[TURTLE_POSE](x=0.5 * k, y=2.0, theta=0.0), TURTLE_POSE),
                T0 + k * 10**9)
        for k in range(5)
    ]  # fmt: skip
    log = write_mcap(tmp_path / "turtle.mcap", messages, {TURTLE_POSE: own.definition(TURTLE_POSE)})
    text = run("info", log, "--suggest-mapping", "/turtle1/pose").stdout
    assert 'frame_override = "map"' in text
    out, words = build_as_suggested(text, log, tmp_path)
    assert "--map-frame" not in words
    assert run_json("info", out, "--format", "json")["counts"]["used"] == 5
