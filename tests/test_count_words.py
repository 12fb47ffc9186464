"""Messages with a count read right for one and for more: "1 message cannot be found and is
not read", "2 messages cannot be found and are not read" (a damaged bag's index said "1
message cannot be found and are not read"; a salvaged sqlite3 file "1 messages are read").
Each text is built by the function the reader calls, with the count given, so the expected
words follow from the count alone."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.formats.log_builders import T0


@pytest.mark.parametrize(
    ("missing", "said"),
    [
        (1, "1 message cannot be found and is not read"),
        (2, "2 messages cannot be found and are not read"),
    ],
)
def test_a_bag_chunk_whose_index_lists_too_few(missing: int, said: str) -> None:
    from aion_cli.formats.bag_reader import unindexed_text

    text = unindexed_text("b.bag", 4096, missing, missing)
    assert text.endswith(f": {said}"), text
    # the chunk's whole count, with its own noun
    listed = "1 message" if missing == 1 else f"{missing} messages"
    assert f"lists 0 of the {listed} its chunk info gives the chunk at byte 4096" in text


@pytest.mark.parametrize(
    ("n", "read", "lost"),
    [
        (1, "1 message is read", "1 cannot be (ids 7) and is lost"),
        (2, "2 messages are read", "2 cannot be (ids 7 to 8) and are lost"),
    ],
)
def test_a_salvaged_sqlite3_file(n: int, read: str, lost: str) -> None:
    from aion_cli.formats.sqlite_salvage import _ON, _damaged_text

    file = Path("x.db3")
    text = _damaged_text(file, n, [(7, 6 + n)], "disk image is malformed")
    assert text.endswith(f"): {read}, {lost}"), text
    text = _damaged_text(file, n, [(9, _ON)], "disk image is malformed")
    assert text.endswith(f"): {read}, none from id 9 on can be read: they are lost"), text
    text = _damaged_text(file, n, [], "disk image is malformed")
    whole = "its one message is read" if n == 1 else f"all {n} of them are read"
    assert text.endswith(f"not in its messages: {whole}"), text


@pytest.mark.parametrize(
    ("n", "said"), [(1, "dropped 1 item;"), (2, "dropped all 2 items;")]
)
def test_a_mapping_filter_that_dropped_every_item(n: int, said: str) -> None:
    from aion_cli.build_hints import _filter_hint

    text = _filter_hint(["/people"], {"filter": n}, {"u0": n})
    assert f"the --detections-mapping's filter {said} its field held u0 ({n})" in text


@pytest.mark.parametrize(("n", "said"), [(1, "after 1 message,"), (2, "after 2 messages,")])
def test_an_mcap_cut_between_two_records(tmp_path: Path, n: int, said: str) -> None:
    """A recording cut short after ``n`` whole messages (no chunks, no summary)."""
    from mcap.writer import Writer

    from aion_cli.formats.logs import open_logs

    path = tmp_path / "cut.mcap"
    with path.open("wb") as f:
        w = Writer(f, use_chunking=False)
        w.start(profile="ros2")
        schema = w.register_schema("std_msgs/msg/Empty", "ros2msg", b"")
        channel = w.register_channel("/e", "cdr", schema)
        for k in range(n):
            w.add_message(channel, T0 + k, b"\x00\x01\x00\x00", T0 + k)
        # no finish(): the file ends after the last message record
    with open_logs([path]) as logs:
        assert logs.total() == n
        (warning,) = [w for w in logs.warnings if "truncated MCAP" in w]
    assert f"ends at byte {path.stat().st_size} {said} between two records" in warning


@pytest.mark.parametrize(
    ("n", "said"), [(1, "1 of 3 shards was built"), (2, "2 of 3 shards were built")]
)
def test_shards_a_parallel_build_built_twice(n: int, said: str) -> None:
    from aion_cli.shard_reports import built_twice_note

    note = built_twice_note(["places that drifted"] * n, 3)
    assert note.startswith(f"{said} twice (in a worker, then in sequence) because of places that")
