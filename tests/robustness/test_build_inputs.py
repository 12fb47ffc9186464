"""What ``aion build`` does with its inputs before and while it reads them (issue 14):

* ``--map`` with a log older than the map: refused (exit 2), the map and its inputs untouched;
* the same log, or a byte-identical copy, twice in one build: used once, with a note;
* FIFOs and devices as inputs, and a target that cannot be a map, are refused before hashing;
* a topic that loses more than half its detections is a warning, also with ``-q`` and JSON;
* a continued build that can use none of its detections is exit 2, not a recorded log;
* the summary prints strings from the log as plain text.

Logs are written with ``formats.writers.LogWriter`` (tests/robustness/conftest.py helpers).
An undecodable ``/tf`` message: ``test_build_bad_tf.py``.
"""

from __future__ import annotations

import json
import os
import shlex
import shutil
from pathlib import Path

import pytest

from aion_cli.formats.mapfile import read_manifest
from tests.robustness.conftest import (
    T0,
    Message,
    S,
    assert_one_error,
    assert_same_arrays,
    build_json,
    fails,
    map_arrays,
    person,
    robot_tf,
    run,
    run_process,
    walk,
    write_log,
)

NAN = float("nan")
ESC = "\x1b"


# -- --map with an older log ------------------------------------------------------------------


def test_an_older_log_added_to_a_newer_map_is_refused_and_not_recorded(tmp_path: Path) -> None:
    """Before: exit 0, every detection of the older log dropped as ``before_window``, and its
    sha256 recorded, so it could never be added again."""
    old = write_log(tmp_path / "old.mcap", walk(1200))
    new = write_log(tmp_path / "new.mcap", walk(1200, start_s=7200))
    target = tmp_path / "m.aion"
    build_json(new, "-o", target)
    before = target.read_bytes()
    result = run("build", old, "--map", target)
    fails(
        result,
        "the detections of old.mcap start at 2026-11-23 08:00:00 UTC",
        "m.aion has already closed every window before 2026-11-23 10:10:00 UTC",
        "logs must be added to a map in time order",
    )
    assert (
        f"hint: rebuild the map from all logs at once (aion build new.mcap {shlex.quote(str(old))} "
        "-o NEW.aion)"
        in result.stderr
    )
    assert target.read_bytes() == before
    assert [i["name"] for i in read_manifest(target)["inputs"]] == ["new.mcap"]
    # all logs at once is the documented way, and equals adding them in time order
    together = build_json(new, old, "-o", tmp_path / "all.aion")
    assert together["detections"]["used"] == 2400
    build_json(old, "-o", tmp_path / "steps.aion")
    build_json(new, "--map", tmp_path / "steps.aion")
    assert_same_arrays(map_arrays(tmp_path / "steps.aion"), map_arrays(tmp_path / "all.aion"))


def test_a_log_reaching_back_into_closed_windows_is_refused(tmp_path: Path) -> None:
    """A log that starts in the map's open window is fine; one that starts a window earlier is
    refused even though most of it is new (its first detections would be lost)."""
    first = write_log(tmp_path / "a.mcap", walk(1200))  # windows 0, 1: window 1 stays open
    target = tmp_path / "m.aion"
    build_json(first, "-o", target)
    overlap_open = write_log(tmp_path / "b.mcap", walk(600, start_s=1200))
    build_json(overlap_open, "--map", target)  # starts in the open window 2
    # another person (the same one at the same stamps would hold b.mcap whole: its copy)
    early = write_log(tmp_path / "c.mcap", walk(1200, start_s=1100, xyz=(2.2, 0.1, 0.0)))
    fails(run("build", early, "--map", target), "logs must be added to a map in time order")
    assert [i["name"] for i in read_manifest(target)["inputs"]] == ["a.mcap", "b.mcap"]


@pytest.mark.parametrize("workers", ["1", "2"])
def test_logs_out_of_time_order_name_the_rebuild_in_both_routes(
    tmp_path: Path, workers: str
) -> None:
    """A later and an older log added to a map at once: one process refuses them as the
    batch of detections reaches back (``check_after_open``), two as the fold meets the older
    log's shard (``shard_fold._check_order``), which said "the messages of old.mcap ... the
    map has already closed" and "rebuild the map from all logs at once" naming none. Both
    routes give the command (the map's input, then the logs) and name the map."""
    new = write_log(tmp_path / "new.mcap", walk(1200, start_s=7200))
    target = tmp_path / "m.aion"
    build_json(new, "-o", target)
    before = target.read_bytes()
    later = write_log(tmp_path / "later.mcap", walk(600, start_s=14400, xyz=(2.2, 0.1, 0.0)))
    old = write_log(tmp_path / "old.mcap", walk(600, xyz=(3.2, 0.1, 0.0)))
    result = run("build", later, old, "--map", target, "--workers", workers)
    named = "later.mcap, old.mcap" if workers == "1" else "old.mcap"  # the shard's own
    fails(
        result,
        f"the detections of {named} start at 2026-11-23 08:00:00 UTC, but m.aion has already "
        "closed every window before 2026-11-23 10:10:00 UTC",
    )
    listed = " ".join(shlex.quote(str(p)) for p in (later, old))
    assert f"hint: rebuild the map from all logs at once (aion build new.mcap {listed} -o " \
        "NEW.aion)" in result.stderr  # fmt: skip
    assert target.read_bytes() == before


def test_both_routes_refuse_a_log_by_its_datas_times_not_its_first_message(
    tmp_path: Path,
) -> None:
    """The map's window 08:10 (of a.mcap, 08:00..08:20) is open. ``tf.mcap``'s transforms
    start at 08:01:40, its detections at 08:21:40: a sequential build took it (transforms
    are not window data), a parallel one refused it by its first message. ``stamps.mcap``
    is logged from 08:21:40 but stamped 800 s earlier, from 08:08:20: a sequential build
    refused it (those detections would fall in closed windows), a parallel one took it,
    dropping them. Both routes now judge a log by its detections' stamps: the same
    outcome, and the same map where it is taken."""
    first = write_log(tmp_path / "a.mcap", walk(1200))
    later = write_log(tmp_path / "later.mcap", walk(600, start_s=14400, xyz=(2.2, 0.1, 0.0)))
    transforms = [robot_tf(T0 + k * S, "cam") for k in range(100, 1400, 10)]
    tf_first = write_log(tmp_path / "tf.mcap", [*transforms, *walk(100, 1300, (3.2, 0.1, 0.0))])
    lagging = [person(T0 + (1300 + k) * S, (3.3, 0.1, 0.0), header_ns=T0 + (500 + k) * S)
               for k in range(100)]  # fmt: skip
    stamped_early = write_log(tmp_path / "stamps.mcap", lagging)
    target = tmp_path / "m.aion"
    build_json(first, "-o", target)
    built = {}
    for workers in ("1", "2"):
        out = tmp_path / f"tf-{workers}.aion"
        report = build_json(later, tf_first, "--map", target, "-o", out, "--workers", workers)
        assert report["detections"]["used"] == 700
        built[workers] = map_arrays(out)
        refused = run("build", later, stamped_early, "--map", target, "--workers", workers,
                      "-o", tmp_path / f"stamps-{workers}.aion")  # fmt: skip
        fails(refused, "start at 2026-11-23 08:08:20 UTC, but m.aion has already closed "
              "every window before 2026-11-23 08:10:00 UTC")  # fmt: skip
        assert "the detections of" in refused.stderr
        assert not (tmp_path / f"stamps-{workers}.aion").exists()
    assert_same_arrays(built["1"], built["2"])


def test_a_log_overlapping_the_maps_data_in_its_open_window_is_noted(tmp_path: Path) -> None:
    """A log that starts before the map's data ends but inside its open window is accepted,
    and the map then differs from one build of both (its detections come after the map's,
    not between them): leg_tracker's positive_2 continuing positive_1, which it overlaps, said
    nothing of it. A log that starts after the map's data gets no such note."""
    first = write_log(tmp_path / "a.mcap", walk(1200))  # 08:00:00 .. 08:19:59, window 1 open
    target = tmp_path / "m.aion"
    build_json(first, "-o", target)
    later = write_log(tmp_path / "later.mcap", walk(60, start_s=1200))
    clean = build_json(later, "--map", target, "-o", tmp_path / "clean.aion")
    assert not [n for n in clean["notes"] if "data ends" in n]
    # another person (the same one at the same stamps is a.mcap cut: refused as its copy)
    inside = write_log(tmp_path / "inside.mcap", walk(240, start_s=900, xyz=(2.2, 0.1, 0.0)))
    # batches of 10 detections: the note is made once, from the first
    report = build_json(inside, "--map", target, "-o", tmp_path / "i.aion", "--batch-size", "10")
    noted = [n for n in report["notes"] if "data ends" in n]
    assert len(noted) == 1, noted
    assert noted[0].startswith(
        "the detections of inside.mcap start at 2026-11-23 08:15:00 UTC, before m.aion's data "
        "ends (2026-11-23 08:19:59 UTC): they are learnt after the map's"
    )


def test_a_parallel_build_notes_the_overlap_too(tmp_path: Path) -> None:
    """The same overlapping log with a later one, built in two worker processes (the default
    --workers on a machine of several cores): the shards are built apart from the map, so
    their builds make no note; the parent makes the sequential build's, once (it said only
    that the first shard was learnt in sequence onto the map)."""
    first = write_log(tmp_path / "a.mcap", walk(1200))
    target = tmp_path / "m.aion"
    build_json(first, "-o", target)
    inside = write_log(tmp_path / "inside.mcap", walk(240, start_s=900))
    later = write_log(tmp_path / "later.mcap", walk(120, start_s=7200))
    one = build_json(inside, later, "--map", target, "-o", tmp_path / "one.aion", "--workers", "1")
    two = build_json(inside, later, "--map", target, "-o", tmp_path / "two.aion", "--workers", "2")
    assert len(two["workers"]) == 2  # built in parallel
    noted = [[n for n in r["notes"] if "data ends" in n] for r in (one, two)]
    assert len(noted[0]) == 1, noted
    assert noted[1] == noted[0]


# -- the same input twice ---------------------------------------------------------------------


def test_the_same_log_twice_is_used_once(tmp_path: Path) -> None:
    """Before: ``build a a`` and ``build a copy-of-a`` counted every detection twice."""
    log = write_log(tmp_path / "a.mcap", walk(600))
    copy = tmp_path / "copy.mcap"
    shutil.copyfile(log, copy)
    once = build_json(log, "-o", tmp_path / "once.aion")
    given = f"{log} is given twice: it is used once"
    copied = f"{copy} is the same log as {log} (same sha256): it is used once"
    for args, other, note in [((log, log), log, given), ((log, copy), copy, copied)]:
        out = tmp_path / f"twice_{other.stem}.aion"
        report = build_json(*args, "-o", out)
        assert report["detections"] == once["detections"]
        assert [i["name"] for i in report["inputs"]] == ["a.mcap"]
        assert note in report["notes"]
        assert_same_arrays(map_arrays(out), map_arrays(tmp_path / "once.aion"))



def test_a_short_log_in_two_containers_is_warned_of(tmp_path: Path) -> None:
    """A four-minute recording converted to an MCAP and to a bag, both given: its people were
    counted twice without a word, since logs warned of had to share a window (10 min) of
    time, more than these logs hold. Logs that share half of the shorter one's time warn
    too; a short log beside another, or brushing it, does not."""
    messages = walk(240)  # 4 min
    mcap = write_log(tmp_path / "run.mcap", messages)
    bag = write_log(tmp_path / "run.bag", messages, "bag")
    once = build_json(mcap, "-o", tmp_path / "once.aion")["detections"]["used"]
    report = build_json(mcap, bag, "-o", tmp_path / "twice.aion", "--workers", "1")
    assert report["detections"]["used"] == 2 * once  # what the warning is about
    (warning,) = [w for w in report["warnings"] if "count twice" in w]
    assert warning.startswith("run.mcap and run.bag both hold /tracks from ")
    assert "(3m59s)" in warning  # 240 messages a second apart
    later = write_log(tmp_path / "later.bag", walk(240, start_s=300), "bag")
    brush = write_log(tmp_path / "brush.bag", walk(240, start_s=200), "bag")  # 40 s shared
    for other in (later, brush):
        apart = build_json(mcap, other, "-o", tmp_path / "apart.aion", "--workers", "1")
        assert not [w for w in apart["warnings"] if "count twice" in w]


def test_a_bag_folder_given_as_dot_names_the_map_after_the_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``cd run && aion build .``: the default map name comes from the log's name, and "."
    has none: "error: internal error: ValueError: PosixPath('.') has an empty name". The map
    is now named after the folder and written beside it, as ``aion build run`` writes it."""
    bag = write_log(tmp_path / "run", walk(30), "rosbag2-mcap")
    monkeypatch.chdir(bag)
    report = build_json(".")
    assert Path(report["map"]).resolve() == tmp_path / "run.aion"
    assert map_arrays(tmp_path / "run.aion")
    monkeypatch.chdir(tmp_path)
    again = build_json("run", "-o", tmp_path / "again.aion")
    assert again["detections"] == report["detections"]

# -- inputs and targets checked before hashing ------------------------------------------------


def test_a_fifo_or_a_device_as_log_is_refused_at_once(tmp_path: Path) -> None:
    """Before: hashing read the FIFO (blocked forever) or /dev/zero (forever, at disk speed)."""
    fifo = tmp_path / "pipe.mcap"
    os.mkfifo(fifo)
    for path, kind in [(fifo, "a FIFO (named pipe)"), (Path("/dev/zero"), "a character device")]:
        result = run_process("build", path, "-o", tmp_path / "m.aion", timeout=30)
        assert result.returncode == 2, result.stderr
        assert_one_error(result.stderr, f"{path} is {kind}, not a regular file")
    assert not (tmp_path / "m.aion").exists()


def test_a_target_that_cannot_be_a_map_is_refused_before_hashing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Before: a long log was hashed (and read) first, and only the write failed."""
    log = write_log(tmp_path / "a.mcap", walk(60))

    def no_hashing(path: Path) -> dict[str, object]:
        raise AssertionError(f"hashed {path} before checking the target")

    monkeypatch.setattr("aion_cli.provenance.provenance", no_hashing)
    notes = tmp_path / "notes.txt"
    notes.write_text("my notes\n")
    fails(run("build", log, "-o", notes), "it exists and is not an aion map")
    assert notes.read_text() == "my notes\n"
    fifo = tmp_path / "out.aion"
    os.mkfifo(fifo)
    result = run("build", log, "-o", fifo)
    assert result.exit_code == 2, result.stderr
    assert "Traceback" not in result.stderr



def test_a_map_given_as_the_log_is_named_a_map(tmp_path: Path) -> None:
    """``aion build office.aion`` (a map where a log belongs, no ``-o``: the map is its own
    default output) said "the map would overwrite the log office.aion", calling the map a log
    and hinting at another output. It now says it is a map and how to extend or query it, as
    ``aion build office.aion -o other.aion`` does; the map is left as it was."""
    log = write_log(tmp_path / "office.mcap", walk(60))
    office = tmp_path / "office.aion"
    assert run("build", log, "-o", office).exit_code == 0
    before = office.read_bytes()
    result = run("build", office)
    fails(result, f"{office} is an aion map, not a log")
    assert f"aion build LOG --map {office}" in result.stderr
    assert "overwrite the log" not in result.stderr
    assert office.read_bytes() == before
    fails(run("build", log, "-o", log), f"the map would overwrite the log {log}")  # a log

# -- losses are never silent ------------------------------------------------------------------


def half_lost(n_bad: int, topic: str = "/tracks") -> list[Message]:
    """100 person messages, the last ``n_bad`` with a NaN position."""
    msgs = [
        person(T0 + k * S, (NAN, 0.0, 0.0) if k >= 100 - n_bad else (2.1, 0.1, 0.0))
        for k in range(100)
    ]
    return [(topic, *m[1:]) for m in msgs]


def test_a_topic_losing_most_of_its_detections_warns_even_when_quiet(tmp_path: Path) -> None:
    log = write_log(tmp_path / "lossy.mcap", half_lost(60))
    warning = "/tracks: 60 of its 100 detections (60 %) could not be used (dropped: nan 60)"
    quiet = run("build", log, "-o", tmp_path / "q.aion", "-q")
    assert quiet.exit_code == 0, quiet.stderr
    assert quiet.stderr.strip() == f"warning: {warning}"
    as_json = run("build", log, "-o", tmp_path / "j.aion", "--format", "json")
    assert as_json.exit_code == 0, as_json.stderr
    report = json.loads(as_json.stdout)
    assert warning in report["warnings"]
    assert f"warning: {warning}" in as_json.stderr
    assert report["detections_by_topic"] == {
        "/tracks": {"read": 100, "used": 40, "dropped": {"nan": 60}}
    }
    table = run("build", log, "-o", tmp_path / "t.aion")
    assert f"warning: {warning}" in table.stderr


def test_a_minor_loss_is_counted_without_the_warning(tmp_path: Path) -> None:
    report = build_json(write_log(tmp_path / "ok.mcap", half_lost(40)), "-o", tmp_path / "m.aion")
    assert report["detections"]["dropped"] == {"nan": 40}
    assert not any("could not be used" in w for w in report["warnings"])


@pytest.mark.parametrize("mode", [(), ("-q",), ("--format", "json")])
def test_a_continued_build_that_uses_nothing_is_exit_2(
    mode: tuple[str, ...], tmp_path: Path
) -> None:
    """Before: exit 0 with a warning, and the log recorded in the map (never to be added again
    once fixed)."""
    target = tmp_path / "m.aion"
    build_json(write_log(tmp_path / "a.mcap", walk(100)), "-o", target)
    before = target.read_bytes()
    lost = [person(T0 + (3600 + k) * S, (NAN, 0.0, 0.0)) for k in range(50)]
    log = write_log(tmp_path / "b.mcap", lost)
    result = run("build", log, "--map", target, *mode)
    fails(result, "none of the 50 people detections read could be used (dropped: nan 50)")
    assert "the map was left as it was" in result.stderr
    assert result.stdout == ""
    assert target.read_bytes() == before



@pytest.mark.parametrize("workers", ["1", "2"])
def test_a_continued_build_counts_the_new_logs_and_the_map_apart(
    workers: str, tmp_path: Path
) -> None:
    """``aion build b.mcap --map m.aion``: the table said "detections used 50" beside the
    whole map's nodes, windows and time span, while ``aion info`` said "130 of 130": nothing
    told the new logs' count from the map's. The rows now say which is which, and JSON
    ``map_detections`` holds the map's, as info counts them."""
    first = write_log(tmp_path / "a.mcap", walk(80))
    second = write_log(tmp_path / "b.mcap", walk(50, start_s=7200))
    alone = build_json(second, "-o", tmp_path / "b.aion")["detections"]["used"]
    target = tmp_path / "m.aion"
    before = build_json(first, "-o", target)["detections"]["used"]
    assert (before, alone) == (80, 50)  # one detection per message
    report = build_json(second, "--map", target, "--workers", workers)
    assert report["detections"]["used"] == alone
    assert report["map_detections"] == {"read": before + alone, "used": before + alone}
    info = json.loads(run("info", target, "--format", "json").stdout)
    assert (info["counts"]["read"], info["counts"]["used"]) == (before + alone, before + alone)
    third = write_log(tmp_path / "c.mcap", walk(20, start_s=14400))
    table = " ".join(run("build", third, "--map", target, "--workers", workers).stderr.split())
    assert "detections read (new logs) │ 20 │" in table
    assert "detections used (new logs) │ 20 │" in table
    assert "detections used in the map │ 150 of 150 │" in table
    fresh = " ".join(run("build", first, "-o", tmp_path / "f.aion").stderr.split())
    assert "detections used │ 80 │" in fresh  # a new map: one count, as before
    assert "(new logs)" not in fresh
    assert "in the map" not in fresh

# -- strings from the log are plain text ------------------------------------------------------


def test_the_summary_prints_names_from_the_log_as_plain_text(tmp_path: Path) -> None:
    """A topic named with an escape sequence and a TF frame named like rich markup reach the
    summary's warnings and notes escaped, never as terminal codes or styling."""
    topic = "/tr\x1b[2Jacks"
    msgs = [*half_lost(60, topic), robot_tf(T0, child="[red]cam\x07")]
    log = write_log(tmp_path / "odd.mcap", sorted(msgs, key=lambda m: m[3]))
    result = run("build", log, "-o", tmp_path / "m.aion", "--detections-topic", topic)
    assert result.exit_code == 0, result.stderr
    assert ESC not in result.stderr
    assert "\x07" not in result.stderr
    assert "warning: /tr\\x1b[2Jacks: 60 of its 100 detections" in result.stderr
    # the warning naming the frame to give (it says what the chain note said: one of them)
    assert "e.g. --base-frame [red]cam\\x07" in result.stderr


def test_an_older_log_is_refused_with_times_on_the_maps_clock(tmp_path: Path) -> None:
    """A map built with ``--tz Asia/Tokyo`` gives its summary's times on that clock; refusing
    an older log it gave them in UTC. Now on the map's clock too: 08:00 UTC is 17:00+09:00."""
    old = write_log(tmp_path / "old.mcap", walk(1200))
    new = write_log(tmp_path / "new.mcap", walk(1200, start_s=7200))
    target = tmp_path / "m.aion"
    build_json(new, "-o", target, "--tz", "Asia/Tokyo")
    result = run("build", old, "--map", target)
    fails(
        result,
        "the detections of old.mcap start at 2026-11-23 17:00:00+09:00",
        "m.aion has already closed every window before 2026-11-23 19:10:00+09:00",
    )
    assert " UTC" not in result.stderr


@pytest.mark.parametrize("workers", ["1", "2"])
def test_the_refusals_rebuild_keeps_the_maps_clock(
    tmp_path: Path, workers: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The hint's rebuild of a map built with ``--tz Asia/Tokyo`` (logs that declare no zone)
    had no ``--tz``: followed, it built a map on UTC, whose days and daily profiles are other
    hours. It names the map's zone now, by either route, and the map it builds is on it."""
    old = write_log(tmp_path / "old.mcap", walk(1200))
    new = write_log(tmp_path / "new.mcap", walk(1200, start_s=7200))
    target = tmp_path / "m.aion"
    build_json(new, "-o", target, "--tz", "Asia/Tokyo")
    result = run("build", old, "--map", target, "--workers", workers)
    hint = next(line for line in result.stderr.splitlines() if line.startswith("hint: "))
    command = shlex.split(hint.split("(", 1)[1].rsplit(")", 1)[0])
    assert command[:2] == ["aion", "build"]
    assert command[-4:] == ["--tz", "Asia/Tokyo", "-o", "NEW.aion"], hint
    rebuilt = tmp_path / "NEW.aion"
    monkeypatch.chdir(tmp_path)  # the hint names the map's inputs as the map recorded them
    build_json(*command[2:-1], rebuilt)
    assert read_manifest(target)["timezone"] == "Asia/Tokyo"
    assert read_manifest(rebuilt)["timezone"] == "Asia/Tokyo"
