"""Hostile detection payloads: arrays of a million variable-size elements, arrays whose every
element changes size, counts larger than the payload.

The numpy decoders read variable-size elements with :func:`formats.detections.wire.walk`,
whose Python loop runs once per *run* of equally sized elements: the tests count those rounds
(``Joined.walk_rounds``) instead of timing anything. Payloads are laid out by hand (rosbags
needs ~10 s to serialise a million persons); the layout is checked against rosbags'
deserializer on a smaller count first.
"""

from __future__ import annotations

import struct
import tracemalloc
from typing import Any

import numpy as np
import pytest

from aion_cli.errors import MessageDecodeError
from aion_cli.formats.detections import adapter as adapter_module
from aion_cli.formats.detections import adapter_for, hash_id, wire
from aion_cli.formats.detections.fast import decode_people
from aion_cli.formats.detections.wire import join_payloads
from aion_cli.formats.raw import RawMessage
from tests.formats.ros_messages import reference

PEOPLE = "people_msgs/msg/People"
SEC, NSEC = 1_795_420_800, 5


def _person(offset: int, name: bytes, x: float, cdr: bool) -> bytes:
    """One people_msgs/Person starting at payload offset ``offset`` (CDR alignment is
    relative to the payload start): name, position (x, 2, 0), velocity (0.5, 0, 0),
    reliability 1, no tagnames, no tags."""
    if cdr:
        out = struct.pack("<I", len(name) + 1) + name + b"\x00"
        out += b"\x00" * (-(offset + len(out)) % 8)
    else:
        out = struct.pack("<I", len(name)) + name
    out += struct.pack("<7d", x, 2.0, 0.0, 0.5, 0.0, 0.0, 1.0)
    return out + struct.pack("<II", 0, 0)


def people_payload(names: list[bytes], cdr: bool, xs: Any = None) -> bytes:
    """A People message (frame ``map``) with one person per name; person k at x = ``xs[k]``
    (default k). Runs of equal names are laid out once and repeated, so a million persons
    take milliseconds."""
    if cdr:
        head = struct.pack("<iII", SEC, NSEC, 4) + b"map\x00"
    else:
        head = struct.pack("<IIII", 0, SEC, NSEC, 3) + b"map"
    out = bytearray(head + struct.pack("<I", len(names)))
    xs = np.arange(len(names), dtype=np.float64) if xs is None else xs
    for k, name in enumerate(names):
        out += _person(len(out), name, float(xs[k]), cdr)
    return (b"\x00\x01\x00\x00" if cdr else b"") + bytes(out)


def uniform_people(n: int, cdr: bool) -> bytes:
    """``n`` persons with empty names at x = 1. After the first, every person has the same
    size and CDR alignment phase, so its bytes are laid out once and repeated."""
    head = _count_offset(cdr)
    one = people_payload([b""], cdr, xs=[1.0])
    two = people_payload([b"", b""], cdr, xs=[1.0, 1.0])
    return one[:head] + struct.pack("<I", n) + one[head + 4 :] + two[len(one) :] * (n - 1)


def _count_offset(cdr: bool) -> int:
    """Where the person count sits in a People payload (after the header)."""
    return len(people_payload([], cdr)) - 4


def message(data: bytes, cdr: bool) -> RawMessage:
    return RawMessage("/people", PEOPLE, SEC * 10**9, data, "cdr" if cdr else "ros1")


@pytest.mark.parametrize("cdr", [True, False])
def test_the_hand_made_layout_is_what_rosbags_reads(cdr: bool) -> None:
    names = [b"", b"ann", b"bob", b"person_12", b""]
    ref = reference(message(people_payload(names, cdr), cdr))
    assert [p.name for p in ref.people] == [n.decode() for n in names]
    assert [p.position.x for p in ref.people] == [0.0, 1.0, 2.0, 3.0, 4.0]
    assert ref.header.frame_id == "map"
    ref = reference(message(uniform_people(1000, cdr), cdr))
    assert len(ref.people) == 1000
    assert all(p.position.x == 1.0 and p.velocity.x == 0.5 for p in ref.people)


@pytest.mark.parametrize("cdr", [True, False])
def test_a_million_persons_decode_in_a_few_vectorised_rounds(cdr: bool) -> None:
    """The issue's message: one People message with 10^6 persons (a 72 MB payload that
    compresses to ~11 KB) took 82 s, one Python loop iteration per person. Now the walk runs
    a handful of rounds (each one vectorised over all persons it reads)."""
    n = 1_000_000
    data = uniform_people(n, cdr)
    j = join_payloads([message(data, cdr)], cdr)
    decoded = decode_people(j)
    assert j.walk_rounds <= 12, j.walk_rounds
    assert len(decoded.owner) == n
    np.testing.assert_array_equal(decoded.xyz[:, 0], 1.0)
    np.testing.assert_array_equal(decoded.xyz[:, 1], 2.0)
    np.testing.assert_array_equal(decoded.velocity[:, 0], 0.5)
    np.testing.assert_array_equal(decoded.track_id, -1)  # empty names: no id
    # and through the adapter, as a build decodes it
    adapter = adapter_for(PEOPLE)
    assert adapter is not None
    frames = adapter.decode([message(data, cdr)])
    assert len(frames) == n
    assert frames.frame_names()[:1] == ["map"]
    np.testing.assert_array_equal(frames.t_ns, SEC * 10**9 + NSEC)


@pytest.mark.parametrize("cdr", [True, False])
def test_names_of_many_lengths_cost_one_round_per_length_change(cdr: bool) -> None:
    """100,000 persons named p0 .. p99999 (five name lengths): ids are the hashes of the
    names, positions as laid out; the rounds stay in the dozens."""
    names = [f"p{k}".encode() for k in range(100_000)]
    data = people_payload(names, cdr)
    j = join_payloads([message(data, cdr)], cdr)
    decoded = decode_people(j)
    assert j.walk_rounds <= 60, j.walk_rounds
    np.testing.assert_array_equal(decoded.xyz[:, 0], np.arange(100_000.0))
    picks = [0, 9, 10, 99, 12_345, 99_999]
    assert decoded.track_id[picks].tolist() == [hash_id(names[k]) for k in picks]


def _alternating(n: int) -> list[bytes]:
    """Names whose persons alternate between two sizes in both encodings."""
    return [b"a" if k % 2 else b"abcdefghijklm" for k in range(n)]


@pytest.mark.parametrize("cdr", [True, False])
def test_every_element_changing_size_hits_the_round_budget(
    cdr: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An array whose every person differs in size from the one before needs one round per
    person: past the budget the numpy decoder gives up with a decode error, and the adapter
    reads the (small) message through rosbags instead -- the same rows."""
    monkeypatch.setattr(wire, "MAX_WALK_ROUNDS", 100)
    names = _alternating(1000)
    m = message(people_payload(names, cdr), cdr)
    adapter = adapter_for(PEOPLE)
    assert adapter is not None
    assert adapter.fast is not None
    with pytest.raises(MessageDecodeError, match="runs of differently sized elements"):
        adapter.fast(join_payloads([m], cdr))
    got = adapter.decode([m])
    np.testing.assert_array_equal(got.xyz[:, 0], np.arange(1000.0))
    assert got.track_id[:2].tolist() == [hash_id(names[0]), hash_id(names[1])]


def test_a_big_message_the_numpy_decoder_refuses_is_a_counted_failure(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Past the round budget *and* too big for the generic decoder: the message is dropped
    and counted (``undecodable``), with the reason kept for the build's warning; the good
    messages beside it are used."""
    monkeypatch.setattr(wire, "MAX_WALK_ROUNDS", 100)
    monkeypatch.setattr(adapter_module, "GENERIC_MAX_PAYLOAD", 10_000)
    bad = message(people_payload(_alternating(1000), True), True)
    good = message(people_payload([b"ann", b"bob"], True), True)
    adapter = adapter_for(PEOPLE)
    assert adapter is not None
    got = adapter.decode([good, bad, good], on_error="skip")
    assert got.filtered == {"undecodable": 1}
    np.testing.assert_array_equal(got.msg_index, [0, 0, 2, 2])
    assert adapter.first_error is not None
    assert "runs of differently sized elements" in adapter.first_error.message


def test_the_generic_decoder_refuses_payloads_over_its_limit(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Types without a numpy decoder go through rosbags objects (a Python loop per element):
    a payload over GENERIC_MAX_PAYLOAD is a decode error naming the limit, before rosbags."""
    monkeypatch.setattr(adapter_module, "GENERIC_MAX_PAYLOAD", 1000)
    from tests.formats.ros_messages import header, raw

    people: list[dict[str, Any]] = [{"pos": {"x": 1.0}, "object_id": "a"}] * 20
    msg = {"header": header(1, 2, "map"), "people": people}
    m = raw("people_msgs/msg/PositionMeasurementArray", msg, 2)
    assert len(m.data) > 1000
    adapter = adapter_for(m.msgtype)
    assert adapter is not None
    assert adapter.fast is None
    with pytest.raises(MessageDecodeError, match="more than the 1,000 bytes"):
        adapter.decode([m])
    small = raw("people_msgs/msg/PositionMeasurementArray", {**msg, "people": people[:2]}, 2)
    assert len(adapter.decode([small])) == 2


@pytest.mark.parametrize("cdr", [True, False])
@pytest.mark.parametrize("where", ["persons", "tagnames"])
def test_a_count_larger_than_the_payload_is_a_counted_failure_without_allocating(
    cdr: bool, where: str
) -> None:
    """A People message that declares 2^31 - 1 persons (or tag names) in a few dozen bytes:
    a decode failure, counted, with a few hundred KiB traced -- never the declared size."""
    data = bytearray(people_payload([b"ann"], cdr))
    # the person count, or the (last) person's tagnames count: the second-last uint32
    at = _count_offset(cdr) if where == "persons" else len(data) - 8
    assert data[at : at + 4] == struct.pack("<I", 1 if where == "persons" else 0)
    data[at : at + 4] = struct.pack("<I", 2**31 - 1)
    m = message(bytes(data), cdr)
    adapter = adapter_for(PEOPLE)
    assert adapter is not None
    tracemalloc.start()
    try:
        got = adapter.decode([m], on_error="skip")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert got.filtered == {"undecodable": 1}
    assert len(got) == 0
    assert peak < 4 * 1024**2, peak
    assert adapter.first_error is not None
    assert "exceeds the payload" in adapter.first_error.message
