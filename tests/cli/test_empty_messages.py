"""A tracker that publishes detection messages with nobody in them is not silent when nobody
is there: the windows without a message were not recorded, and the advice to declare them as
recording (``aion build --observed``) must not be given. The build counts those messages."""

from __future__ import annotations

from pathlib import Path

import pytest

from aion_cli.formats.mapfile import read_manifest
from aion_cli.manifest import add_counts
from tests.cli.conftest import run, run_json

#: two people, on Monday 2026-01-05 09:00 and Thursday 2026-01-08 09:00 UTC
CSV = (
    "t_ns,track_id,x,y,z,heading_rad,speed_mps\n"
    "1767603600000000000,1,0,0,0,0,1\n"
    "1767862800000000000,2,0,0,0,0,1\n"
)
SPANS = ("--observed", "2026-01-05 09:00..2026-01-05 11:00",
         "--observed", "2026-01-08 09:00..2026-01-08 11:00")
#: convert marks each 2 h span with an empty message every 30 s, both ends included
EMPTY = 2 * (2 * 3600 // 30 + 1)
ADVICE = "if its tracker is silent when nobody is there"


def _convert(tmp_path: Path, name: str, *spans: str) -> Path:
    """A tracker's log (a rosbag2 folder) with an empty message every 30 s over ``spans``,
    written by aion convert --observed without the spans it records (which aion build would
    take as --observed: a tracker's own log declares none)."""
    import yaml

    csv, log = tmp_path / f"{name}.csv", tmp_path / name
    csv.write_text(CSV)
    out = run("convert", csv, "-o", log, *spans)
    assert out.exit_code == 0, out.output
    meta = log / "metadata.yaml"
    doc = yaml.safe_load(meta.read_text())
    doc["rosbag2_bagfile_information"]["custom_data"].pop("aion.observed", None)
    meta.write_text(yaml.safe_dump(doc))
    return log


@pytest.mark.parametrize("workers", ["1", "2"])
def test_empty_messages_are_counted_and_the_silent_advice_is_not_given(
    tmp_path: Path, workers: str
) -> None:
    log = _convert(tmp_path, "two", *SPANS)
    out = tmp_path / "two.aion"
    built = run_json("build", log, "-o", out, "--format", "json", "--workers", workers)
    assert read_manifest(out)["counts"]["empty_messages"] == EMPTY
    (note,) = [n for n in built["notes"] if "fixed sensor observed" in n]
    assert "observed 5% of its logs' time" in note  # the share is still said
    assert ADVICE not in note
    assert f"published {EMPTY} messages with nobody in them" in note
    predicted = run("predict", out, "--time", "2026-01-09 10:00")
    assert predicted.exit_code == 0, predicted.output
    assert "observed 5% of its logs' time" in predicted.stderr
    assert ADVICE not in predicted.stderr


def test_a_tracker_with_no_empty_message_keeps_the_advice(tmp_path: Path) -> None:
    log = _convert(tmp_path, "bare")  # two messages, each with a person
    out = tmp_path / "bare.aion"
    built = run_json("build", log, "-o", out, "--format", "json")
    assert read_manifest(out)["counts"]["empty_messages"] == 0
    assert any(ADVICE in n for n in built["notes"])
    assert ADVICE in run("predict", out, "--time", "2026-01-09 10:00").stderr


def test_continuations_and_merges_add_the_count_and_older_maps_stay_unknown() -> None:
    new = {"read": 1, "used": 1, "dropped": {}, "empty_messages": 5}
    first = add_counts({}, new)
    assert first["empty_messages"] == 5
    assert add_counts(first, new)["empty_messages"] == 10
    older = {"read": 3, "used": 3, "dropped": {}}  # a map from before the count
    assert "empty_messages" not in add_counts(older, {**new, "empty_messages": 0})
    assert add_counts(older, new)["empty_messages"] == 5  # some seen: the tracker sends them
    assert "empty_messages" not in add_counts(first | {"empty_messages": 0}, older)


def test_info_of_the_log_gives_the_advice_only_without_empty_messages(tmp_path: Path) -> None:
    """``aion info LOG`` advised ``--observed`` for the log whose tracker published empty
    messages; it counts them among the first detection messages it decodes (20 per topic: the
    first holds the person of 09:00, the other 19 nobody) and says the tracker is not silent."""
    log = _convert(tmp_path, "two", *SPANS)
    fixed = run_json("info", log, "--format", "json")["fixed_sensor"]
    assert fixed["empty_in_first_messages"] == 19
    said = " ".join(run("info", log).stderr.split())
    assert "5% of its span; the others were not recorded" in said
    assert "if the tracker is silent when nobody is there" not in said
    bare = _convert(tmp_path, "bare")
    bare_fixed = run_json("info", bare, "--format", "json")["fixed_sensor"]
    assert bare_fixed["empty_in_first_messages"] == 0
    assert "if the tracker is silent when nobody is there" in " ".join(
        run("info", bare).stderr.split()
    )
