"""The log readers on damaged and arbitrary bytes, as properties: a valid log of each container
(MCAP ROS 2, MCAP ROS 1, ROS 1 bag, rosbag2 with sqlite3 and with mcap storage) with one to
three damages (cut, bytes overwritten, a span replaced, deleted or repeated) in one of its
files, or its container's magic followed by arbitrary bytes, is read (every message, the first
20 decoded: what ``aion build`` reads) or refused with a typed aion error
(:class:`~aion_cli.errors.AionError`), never another exception. ``test_fuzz.py`` runs
thousands of such mutants in a subprocess with a timer and a memory limit; here hypothesis
draws them and, on a failure, shrinks it to a small damage. The logs hold no scene graph: a
damaged one can make spark_dsg allocate gigabytes, which only the fuzz worker's limit bounds."""

from __future__ import annotations

import contextlib
import shutil
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aion_cli.errors import AionError
from tests.robustness.conftest import T0, S, robot_tf, walk, write_log
from tests.robustness.fuzz_worker import _read_log

CONTAINERS = {
    "a.mcap": "mcap",
    "b.mcap": "mcap-ros1",
    "c.bag": "bag",
    "d_r2": "rosbag2-sqlite3",
    "e_r2": "rosbag2-mcap",
}
MAGIC = {
    "a.mcap": b"\x89MCAP0\r\n",
    "b.mcap": b"\x89MCAP0\r\n",
    "c.bag": b"#ROSBAG V2.0\n",
    "x.db3": b"SQLite format 3\x00",
}


@pytest.fixture(scope="module")
def seeds(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One small valid log per container (people walking, the robot's TF)."""
    folder = tmp_path_factory.mktemp("any_bytes")
    msgs = sorted([*walk(12), *[robot_tf(T0 + 5 * k * S) for k in range(4)]], key=lambda m: m[3])
    for name, container in CONTAINERS.items():
        write_log(folder / name, msgs, container)
    return folder


DAMAGE = st.tuples(
    st.sampled_from(["cut", "overwrite", "replace", "delete", "repeat"]),
    st.floats(0.0, 1.0),  # where, as a fraction of the file
    st.binary(min_size=1, max_size=16),
)


def _damaged(data: bytes, damages: list[tuple[str, float, bytes]]) -> bytes:
    for kind, where, junk in damages:
        at = min(int(where * len(data)), max(len(data) - 1, 0))
        if kind == "cut":
            data = data[:at]
        elif kind == "overwrite":
            data = data[:at] + junk + data[at + len(junk):]
        elif kind == "replace":
            data = data[:at] + junk + data[at + 4 * len(junk):]
        elif kind == "delete":
            data = data[:at] + data[at + len(junk):]
        else:
            data = data[:at] + data[at: at + 8 * len(junk)] + data[at:]
    return data


def _typed_or_read(path: Path) -> None:
    """Read ``path``; a typed error is an answer too (any other exception fails the test)."""
    with contextlib.suppress(AionError):
        _read_log(path)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    name=st.sampled_from(sorted(CONTAINERS)),
    victim=st.integers(0, 10),
    damages=st.lists(DAMAGE, min_size=1, max_size=3),
)
def test_a_damaged_log_of_any_container_is_read_or_refused_with_a_typed_error(
    seeds: Path, name: str, victim: int, damages: list[tuple[str, float, bytes]]
) -> None:
    seed = seeds / name
    with tempfile.TemporaryDirectory() as work:
        target = Path(work) / name
        if seed.is_dir():  # a rosbag2 folder: one of its files damaged
            shutil.copytree(seed, target)
            files = sorted(p for p in target.iterdir() if p.is_file())
            file = files[victim % len(files)]
        else:
            shutil.copyfile(seed, target)
            file = target
        file.write_bytes(_damaged(file.read_bytes(), damages))
        _typed_or_read(target)


@settings(max_examples=100, deadline=None)
@given(name=st.sampled_from(sorted(MAGIC)), tail=st.binary(max_size=512))
def test_a_containers_magic_then_arbitrary_bytes_is_refused_with_a_typed_error(
    name: str, tail: bytes
) -> None:
    with tempfile.TemporaryDirectory() as work:
        path = Path(work) / name
        path.write_bytes(MAGIC[name] + tail)
        _typed_or_read(path)
