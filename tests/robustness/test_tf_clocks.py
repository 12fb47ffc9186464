"""TF stamped on another clock than the detections (a simulation's TF from 0 beside a tracker
on the wall clock, or a TF publisher an hour off): no detection in the robot's frame has a
transform. The build stopped with 'check --map-frame and the log's TF' and no more, or lost
most of a topic with only the counts; now the hint and the warning name the first
detection's stamp and the stamps TF has."""

from __future__ import annotations

from pathlib import Path

from tests.robustness.conftest import (
    T0,
    Message,
    S,
    build_json,
    fails,
    person,
    robot_tf,
    run,
    stamp,
    write_log,
)

N = 1800  # a detection a second in base_link for 30 minutes, a transform every 5 s
WHY = "TF and the detections are stamped on different clocks"


def robot_log(path: Path, tf_start_ns: int) -> Path:
    """The detections stamped from T0; TF's transforms stamped from ``tf_start_ns`` (logged
    with the detections)."""
    messages: list[Message] = []
    for k in range(N):
        messages.append(person(T0 + k * S, (1.1, 0.1, 0.0), frame="base_link"))
        if k % 5 == 0:
            tf = robot_tf(T0 + k * S)
            tf[2]["transforms"][0]["header"]["stamp"] = stamp(tf_start_ns + k * S)
            messages.append(tf)
    return write_log(path, messages)


def test_tf_on_another_clock_is_named_in_the_error(tmp_path: Path) -> None:
    for name, tf_start, shown in (
        ("hour", T0 + 3600 * S, "2026-11-23 09:00:00 UTC to 2026-11-23 09:29:55 UTC"),
        ("sim", 100 * S, "1970-01-01 00:01:40 UTC to 1970-01-01 00:31:35 UTC"),
    ):
        result = run(
            "build", robot_log(tmp_path / f"{name}.mcap", tf_start), "-o", tmp_path / "m.aion"
        )
        fails(result, "none of the 1,800 people detections", "no_transform 1,800")
        hint = result.stderr.split("hint: ", 1)[1]
        assert "the first detection in 'base_link' without a transform is stamped " in hint
        assert "2026-11-23 08:00:00 UTC" in hint
        assert f"TF has map->base_link only from {shown}: {WHY}" in hint


def test_tf_partly_off_names_its_clock_in_the_loss_warning(tmp_path: Path) -> None:
    """TF stamped 20 minutes late: the first 20 of 30 minutes have no transform (1,200
    detections lost), and the loss warning says why; a log stamped right has no such words."""
    report = build_json(robot_log(tmp_path / "late.mcap", T0 + 1200 * S), "-o", tmp_path / "l.aion")
    assert report["detections"]["dropped"]["no_transform"] == 1200
    (warning,) = [w for w in report["warnings"] if "could not be used" in w]
    assert warning.startswith("/tracks: 1,200 of its 1,800 detections (67 %) could not be used")
    assert WHY in warning
    report = build_json(robot_log(tmp_path / "ok.mcap", T0), "-o", tmp_path / "ok.aion")
    assert report["detections"]["used"] >= N - 5  # the last seconds after TF's last sample
    assert all(WHY not in w for w in report["warnings"])


def test_tf_stamped_within_one_second_gives_ends_that_read_apart(tmp_path: Path) -> None:
    """Two transforms 0.4 s apart an hour off: "only from 09:00:00 UTC to 09:00:00 UTC" read
    as one instant; now with the decimals that tell the ends apart."""
    messages = [person(T0 + k * S, (1.1, 0.1, 0.0), frame="base_link") for k in range(60)]
    for k, late_ns in enumerate((0, 400_000_000)):
        tf = robot_tf(T0 + k * S)
        tf[2]["transforms"][0]["header"]["stamp"] = stamp(T0 + 3600 * S + late_ns)
        messages.append(tf)
    result = run("build", write_log(tmp_path / "tf.mcap", messages), "-o", tmp_path / "m.aion")
    fails(result, "none of the 60 people detections")
    shown = "2026-11-23 09:00:00.0 UTC to 2026-11-23 09:00:00.4 UTC"
    assert f"TF has map->base_link only from {shown}: {WHY}" in result.stderr.split("hint: ", 1)[1]
