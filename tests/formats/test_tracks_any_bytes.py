"""The tracks readers on arbitrary and damaged files: every layout's reader, whole
(:func:`formats.tracks.read_track_data`) and streamed (:func:`formats.track_csv.track_chunks`),
reads a file or raises a typed aion error (:class:`~aion_cli.errors.AionError`), never
another exception, whichever layout the file really has; what it reads is time-sorted, with
finite positions."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from aion_cli.errors import AionError
from aion_cli.formats.track_csv import STREAM_LAYOUTS, track_chunks
from aion_cli.formats.track_types import LAYOUTS
from aion_cli.formats.tracks import read_track_data

#: one small valid file of each layout (as tests/formats/test_track_sniff.py guesses them)
VALID = [
    "t_ns,track_id,x,y,z,heading_rad,speed_mps\n1,2,0,0,0,nan,nan\n3,2,1,0,0,0.5,1.0\n",
    "Time,frame_id,x,y,z,ag_id,data_label\n0.01,1,100,200,0,Helmet_3,x\n0.02,2,110,200,0,Helmet_3,x\n",
    "Properties.R1=[ 3 ];\nTRACK.R1=[[10 20 0];[11 21 1];];\n",
    "780\t1.0\t8.46\t3.59\n790\t1.0\t9.57\t3.79\n",
    "1496880000 1497225600\n-8 12\n-3 17\n1496999627.5 1.0 2.0\n",
    "1495617883.77 16.48 -1.00 1.0\n1495617885.10 16.40 -0.99 1.0\n",
    "1495617883.77 16.48 -1.00\n1495617885.10 16.40 -0.99\n",
    "1495706022.77 2.5 -0.9 7.9 1.1 WP4\n1495706023.31 -0.3 5.1 11.5 -4.5 WP11\n",
    "1496223468.9,0,13.8,1.5,0,0.37\n1496223474.4,0,13.4,1.4,0,0.26\n",
    "1351038020.9,9190802,-22.3,1.8,0.3,-0.4\n1351038021.9,91908,-22.0,1.9,0.3,-0.4\n",
    "0.02,12001,-0.046,-3.443,0.141,2.356\n0.42,12001,-0.1,-3.4,0.1,2.3\n",
]
#: values a damaged or hostile file may hold in place of a number
ODD = ["", "nan", "inf", "-inf", "1e308", "-1e308", "1e-320", "99999999999999999999999",
       "-9223372036854775809", "0x10", "1_0", "+", "-", ".", "e5", "１", "\x00", "'", '"',
       "1,5", " ", "\t", ";", "]", "[", "\r", "\ufeff", "\xe9"]


@st.composite
def damaged(draw: st.DrawFn) -> bytes:
    """A valid file of some layout with a few tokens replaced, lines cut, dropped or
    repeated, bytes inserted; or plain arbitrary bytes."""
    if draw(st.integers(0, 9)) == 0:
        return draw(st.binary(max_size=300))
    lines = draw(st.sampled_from(VALID)).splitlines(keepends=True)
    for _ in range(draw(st.integers(1, 4))):
        k = draw(st.integers(0, len(lines) - 1))
        action = draw(st.sampled_from(["token", "cut", "drop", "repeat", "swap"]))
        line = lines[k]
        if action == "token":
            sep = next((c for c in ",\t ;" if c in line), " ")
            parts = line.rstrip("\n").split(sep)
            j = draw(st.integers(0, len(parts) - 1))
            parts[j] = draw(st.sampled_from(ODD) | st.text(max_size=6))
            lines[k] = sep.join(parts) + ("\n" if line.endswith("\n") else "")
        elif action == "cut":
            lines[k] = line[: draw(st.integers(0, len(line)))]
        elif action == "drop" and len(lines) > 1:
            del lines[k]
        elif action == "repeat":
            lines.insert(k, line)
        elif action == "swap":
            j = draw(st.integers(0, len(lines) - 1))
            lines[k], lines[j] = lines[j], lines[k]
    data = "".join(lines).encode("utf-8", "surrogatepass")
    if draw(st.booleans()):
        at = draw(st.integers(0, len(data)))
        data = data[:at] + draw(st.binary(min_size=1, max_size=8)) + data[at:]
    return data


def _read(path: Path, layout: str) -> None:
    """Read ``path`` as ``layout``: a typed error, or detections sorted in time, finite."""
    try:
        batch = read_track_data(path, layout).batch
    except AionError:
        return
    assert (np.diff(batch.t_ns) >= 0).all(), layout
    assert np.isfinite(batch.xyz).all(), layout


def _stream(path: Path, layout: str) -> None:
    try:
        for chunk in track_chunks(path, layout, rows=1):
            assert len(chunk) > 0
            assert np.isfinite(chunk.xyz).all(), layout
    except AionError:
        return


MAGNI = b"Time,frame_id,x,y,z,ag_id,data_label\n0.01,1,100,200,0,Helmet_3,x\n"


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(content=damaged())
# a lone carriage return inside a THÖR-MAGNI line (np.loadtxt's universal newlines end the line
# there), in a line, the header, the cut last line: the csv module's "new-line character seen
# in unquoted field" (_csv.Error) escaped the reader's refusal of the line
@example(content=MAGNI.replace(b"0.01,", b"0\r,"))
@example(content=MAGNI.replace(b"data_label", b"data_label\r,q"))
@example(content=MAGNI + b"0.02\r,2,110")
# the Lincoln CSV's z column not finite: taken as the detection's height (NaN) silently
@example(content=b"1496223468.9,0,13.8,1.5,nan,0.37\n1496223474.4,0,13.4,1.4,0,0.26\n")
# a Lincoln header's start beyond int64 nanoseconds: an OverflowError comparing it with the rows'
@example(content=b"-9223372036854775809 1497225600\n-8 12\n-3 17\n1496999627.5 1.0 2.0\n")
def test_every_layouts_reader_gives_tracks_or_a_typed_error(content: bytes) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "tracks.txt"
        path.write_bytes(content)
        for layout in LAYOUTS:
            _read(path, layout)
        for layout in STREAM_LAYOUTS:
            _stream(path, layout)
