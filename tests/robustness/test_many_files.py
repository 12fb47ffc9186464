"""Input files are opened lazily (issue 14, point 6): a LogSet over thousands of files holds a
few file handles at a time, not one per file (more than about 1,020 inputs used to fail with
EMFILE, "Too many open files").

The read runs in a child process whose open-file limit is lowered to 64 with
``resource.setrlimit(RLIMIT_NOFILE)``, over 2,000 MCAP files with a summary (all covering the
same seconds: every file takes part in the merge at once), 2,000 MCAP files without one and 500
ROS 1 bags (one after the other in time). The messages counted there are the ones written here.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from mcap.records import Message

from tests.formats.craft import McapFile, mcap_parts, records_chunk
from tests.formats.craft_bag import bag_topic, craft_bag
from tests.robustness.conftest import T0, S, walk, write_log

LIMIT = 64
CHILD = """
import json, resource, sys
from pathlib import Path
soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
resource.setrlimit(resource.RLIMIT_NOFILE, ({limit}, hard))
from aion_cli.formats.logs import open_logs
paths = sorted(Path(sys.argv[1]).iterdir())
with open_logs(paths) as logs:
    times = [m.log_time_ns for m in logs.messages()]
    windows = logs.recorded_windows(600 * 10**9).tolist()
    print(json.dumps({{"files": len(logs.files), "total": logs.total(), "times": times,
                      "windows": windows, "warnings": logs.warnings}}))
"""


def read_in_child(folder: Path) -> dict[str, object]:
    done = subprocess.run(
        [sys.executable, "-c", CHILD.format(limit=LIMIT), str(folder)],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    result: dict[str, object] = json.loads(done.stdout)
    return result


@pytest.mark.slow
def test_thousands_of_input_files_need_few_file_handles(tmp_path: Path) -> None:
    src = tmp_path / "src"
    src.mkdir()
    parts = mcap_parts(write_log(src / "one.mcap", walk(3)))
    parts.messages.sort(key=lambda m: m.log_time)
    cid = parts.channels[0].id
    folder = tmp_path / "logs"
    folder.mkdir()

    indexed = McapFile(parts).chunks(parts.messages, 3).bytes()  # three messages, T0 .. T0+2 s
    for k in range(2000):
        (folder / f"a{k:04d}.mcap").write_bytes(indexed)
    expected = [m.log_time for m in parts.messages] * 2000

    data = parts.messages[0].data
    for k in range(2000):  # one message each, a second apart, from T0 + 10 s
        t = T0 + (10 + k) * S
        f = McapFile(parts)
        msg = Message(channel_id=cid, log_time=t, data=data, publish_time=t, sequence=k)
        f.chunk(records_chunk([*parts.schemas, *parts.channels, msg]))
        (folder / f"b{k:04d}.mcap").write_bytes(f.bytes(with_summary=False))
        expected.append(t)

    topic, bag_msgs = bag_topic(write_log(src / "one.bag", walk(1), "bag"), "/tracks")
    payload = bag_msgs[0][1]
    for k in range(500):  # after those
        t = T0 + (3000 + k) * S
        (folder / f"c{k:04d}.bag").write_bytes(craft_bag(topic, [[(t, payload)]]))
        expected.append(t)

    got = read_in_child(folder)
    assert got["files"] == 4500
    assert got["total"] == len(expected) == 8500
    assert got["times"] == sorted(expected)
    assert got["windows"] == sorted({t // (600 * S) for t in expected})
    assert got["warnings"] == []
