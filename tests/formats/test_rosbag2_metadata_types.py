"""A rosbag2 metadata.yaml whose figures are not of their type (found by the long fuzz run of
stop 66, target ``logs``: a topic's ``message_count: $0``). rosbags takes any YAML value
there, and aion's sum of the topic counts failed (``internal error: TypeError: unsupported
operand type(s) for +=: 'int' and 'str'``, exit 1). Now the yaml is not used, as any other
unusable metadata.yaml: the storage files are indexed in memory, and the warning names the
value.

Expected answers: the storage files read with Python's ``sqlite3`` and the ``mcap`` library.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from aion_cli.formats.logs import open_logs
from tests.formats.rosbag2_reference import mcap_messages, sqlite_messages
from tests.robustness.conftest import T0, S, robot_tf, run, walk, write_log


def _topic_count(info: dict[str, Any], value: object) -> str:
    info["topics_with_message_count"][0]["message_count"] = value
    return f"the message_count of /tracks is {value!r}, not an integer"


def _bag_count(info: dict[str, Any], value: object) -> str:
    info["message_count"] = value
    return f"message_count is {value!r}, not an integer"


def _topic_name(info: dict[str, Any], value: object) -> str:
    info["topics_with_message_count"][0]["topic_metadata"]["name"] = value
    return f"a topic's name is {value!r}, not text"


def _start(info: dict[str, Any], value: object) -> str:
    info["starting_time"]["nanoseconds_since_epoch"] = value
    return f"starting_time is {value!r}, not an integer"


@pytest.mark.parametrize("container", ["rosbag2-sqlite3", "rosbag2-mcap"])
@pytest.mark.parametrize(
    ("edit", "value"),
    [(_topic_count, "$0"), (_topic_count, 40.0), (_topic_count, True), (_bag_count, "49"),
     (_topic_name, 7), (_start, "1795420800000000000")],
)
def test_a_figure_of_another_type_is_not_used(
    container: str, edit: Any, value: object, tmp_path: Path
) -> None:
    from ruamel.yaml import YAML

    msgs = sorted([*walk(40), *[robot_tf(T0 + 5 * k * S) for k in range(8)]], key=lambda m: m[3])
    folder = write_log(tmp_path / "bag", msgs, container)
    yaml = YAML(typ="safe")
    data = yaml.load((folder / "metadata.yaml").read_text())
    info = data["rosbag2_bagfile_information"]
    (topic,) = [e for e in info["topics_with_message_count"] if e["topic_metadata"]["name"]
                == "/tracks"]
    info["topics_with_message_count"].remove(topic)
    info["topics_with_message_count"].insert(0, topic)
    named = edit(info, value)
    with (folder / "metadata.yaml").open("w") as f:
        yaml.dump(data, f)
    (storage,) = [p for p in folder.iterdir() if p.suffix in (".db3", ".mcap")]
    read = sqlite_messages if container.endswith("sqlite3") else mcap_messages
    expected = sorted(read(storage))
    assert len(expected) == 48
    with open_logs([folder]) as logs:
        got = sorted((m.topic, m.log_time_ns, m.data) for m in logs.messages())
        warning = logs.warnings[-1]
    assert got == expected
    assert f"metadata.yaml not used ({folder}: not a readable rosbag2 folder (metadata.yaml: " \
        f"{named}))" in warning
    assert "indexed in memory from its 1 storage file" in warning
    result = run("info", folder)
    assert result.exit_code == 0, result.stderr
    assert "messages: 48" in result.stdout
