"""Which tracks layout a file looks like (formats/track_sniff.py): the real datasets' files are
recognised as the layout their README names, synthetic files of every layout too, and what
fits no layout is None, never an exception."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.formats.track_sniff import (
    SNIFF_BYTES,
    UNIX_SECONDS_FROM,
    guess_layout,
    layout_mismatch,
)
from tests.shared_data import real

#: real files and the layout ../shared/data/README.md says they are in
REAL_FILES = [
    (("atc", "atc-1024-9_test.csv"), "atc"),
    (("thor", "thor1-exp-1-run-2.csv"), "thor"),
    (("thor", "thor3-exp-3-run-2.csv"), "thor"),
    (("lincoln", "2017-05-24_25.txt"), "lincoln"),
    (("lincoln", "2017-05-25.txt"), "lincoln"),
    (("lincoln", "2017-05-31_heading.csv"), "lincoln"),
    (("lincoln", "2017-06-09.txt"), "lincoln"),
    (("tracks", "eth_ucy", "biwi_eth.txt"), "eth"),
    (("tracks", "eth_ucy", "students003.txt"), "ucy"),
    (("tracks", "edinburgh", "tracks.01Jul.txt"), "edinburgh"),
]


@pytest.mark.parametrize(("parts", "layout"), REAL_FILES, ids=[p[-1] for p, _ in REAL_FILES])
def test_real_dataset_files_look_like_their_layout(parts: tuple[str, ...], layout: str) -> None:
    guess = guess_layout(real(*parts))
    assert guess is not None
    assert layout in guess.layouts
    assert layout_mismatch(real(*parts), layout) is None


def _write(tmp_path: Path, text: str, name: str = "t.csv") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("text", "layout"),
    [
        ("t_ns,track_id,x,y,z,heading_rad,speed_mps\n1,2,0,0,0,nan,nan\n", "canonical"),
        ("t_ns, track_id, x, y, z, heading_rad, speed_mps\n", "canonical"),
        ("Time,frame_id,x,y,z,ag_id,data_label\n0.01,1,100,200,0,Helmet_3,x\n", "thor-magni"),
        ("Properties.R1=[ 3 ];\nTRACK.R1=[[10 20 0];[11 21 1];];\n", "edinburgh"),
        ("780\t1.0\t8.46\t3.59\n790\t1.0\t9.57\t3.79\n", "eth"),
        ("1496880000 1497225600\n-8 12\n-3 17\n1496999627.5 1.0 2.0\n", "lincoln"),
        ("1495617883.77 16.48 -1.00 1.0\n1495617885.10 16.40 -0.99 1.0\n", "lincoln"),
        ("1495617883.77 16.48 -1.00\n1495617885.10 16.40 -0.99\n", "lincoln"),
        ("1495706022.77 2.5 -0.9 7.9 1.1 WP4\n1495706023.31 -0.3 5.1 11.5 -4.5 WP11\n", "lincoln"),
        ("1496223468.9,0,13.8,1.5,0,0.37\n1496223474.4,0,13.4,1.4,0,0.26\n", "lincoln"),
        ("1351038020.9,9190802,-22.3,1.8,0.3,-0.4\n1351038021.9,91908,-22.0,1.9,0.3,-0.4\n", "atc"),
        ("0.02,12001,-0.046,-3.443,0.141,2.356\n0.42,12001,-0.1,-3.4,0.1,2.3\n", "thor"),
    ],
)
def test_synthetic_files_of_every_layout(tmp_path: Path, text: str, layout: str) -> None:
    guess = guess_layout(_write(tmp_path, text))
    assert guess is not None
    assert guess.layout == layout
    assert guess.why


@pytest.mark.parametrize(
    "content",
    [
        b"",
        b"\n\n# only a comment\n",
        b"\x00\xff\x10binary\x00" * 100,
        b"a,b,c\n1,2,3\n",  # a header of no known layout
        b"1,2,3\n4,5,6\n",  # three comma-separated numbers: no layout has them
        b"1 2 3 4 5 6 7 8\n",
        b"1,2,3,4,5,6\n1,2,3\n",  # ragged
    ],
)
def test_what_fits_no_layout_is_none(tmp_path: Path, content: bytes) -> None:
    path = tmp_path / "x.csv"
    path.write_bytes(content)
    assert guess_layout(path) is None
    assert layout_mismatch(path, "atc") is None
    assert guess_layout(tmp_path / "missing.csv") is None


def test_only_the_start_of_a_long_file_is_read(tmp_path: Path) -> None:
    """A file far longer than SNIFF_BYTES, whose line at the cut is half written, is guessed
    from its whole lines."""
    line = "0.02,12001,-0.046,-3.443,0.141,2.356\n"
    path = _write(tmp_path, line * (3 * SNIFF_BYTES // len(line)))
    guess = guess_layout(path)
    assert guess is not None
    assert guess.layout == "thor"


@settings(max_examples=60, deadline=None)
@given(
    t0=st.floats(0, 4e9, allow_nan=False),
    ids=st.lists(st.integers(1, 10**7), min_size=2, max_size=20),
)
def test_six_numbers_are_atc_or_thor_by_their_clock(t0: float, ids: list[int]) -> None:
    """Six comma-separated numbers: UNIX seconds first -> atc, times from 0 -> thor (never
    lincoln, whose id is always 0)."""
    import tempfile

    rows = "".join(f"{t0 + k:.3f},{i},1.5,-2.5,0.8,1.2\n" for k, i in enumerate(ids))
    with tempfile.TemporaryDirectory() as folder:
        guess = guess_layout(_write(Path(folder), rows))
    assert guess is not None
    assert guess.layout == ("atc" if t0 >= UNIX_SECONDS_FROM else "thor")


def test_a_mismatch_names_the_layout_the_file_looks_like(tmp_path: Path) -> None:
    thor = _write(tmp_path, "0.02,12001,-0.046,-3.443,0.141,2.356\n0.42,12001,-0.1,-3.4,0.1,2.3\n")
    message = layout_mismatch(thor, "atc")
    assert message is not None
    assert "read as the atc layout" in message
    assert "--layout thor" in message
    assert layout_mismatch(thor, "thor") is None
    eth = _write(tmp_path, "780\t1.0\t8.46\t3.59\n790\t1.0\t9.57\t3.79\n", "e.txt")
    assert layout_mismatch(eth, "ucy") is None  # eth and ucy are one format
    assert layout_mismatch(eth, "lincoln") is not None


@settings(max_examples=200, deadline=None)
@given(content=st.binary(max_size=2048) | st.text(max_size=2048).map(str.encode))
def test_any_bytes_give_a_guess_or_none_never_an_error(content: bytes) -> None:
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "x.csv"
        path.write_bytes(content)
        guess = guess_layout(path)
        mismatch = layout_mismatch(path, "canonical")
    assert guess is None or (guess.layouts and guess.why)
    assert mismatch is None or "--layout" in mismatch
