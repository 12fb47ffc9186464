"""``aion.info(logs)``: ``aion info LOG``'s report from Python, before a map is made (the API
had none: a script choosing ``detection_topics`` or ``map_frame`` ran the command and parsed
its JSON). It is the command's JSON document, read by the same function
(:func:`aion_cli.log_report.describe`), its warnings issued as ``AionWarning``."""

from __future__ import annotations

import json
import shutil
import warnings
from pathlib import Path

import pytest

import aion_cli as aion
from aion_cli.errors import InputError
from tests.cli.conftest import Office, run


def _cli(*args: str | Path) -> dict[str, object]:
    result = run("info", *args, "--format", "json")
    assert result.exit_code == 0, result.stderr
    doc = json.loads(result.stdout)
    assert isinstance(doc, dict)
    return doc


def test_info_is_the_command_s_json(office: Office) -> None:
    report = aion.info(office.log)
    assert report == _cli(office.log)
    assert report["will_use"]["detections"]  # type: ignore[index]
    assert aion.info([office.log]) == report  # a list of one, as build takes logs
    # the zone of its times of day as the command's --tz
    assert aion.info(office.log, tz="Asia/Tokyo") == _cli(office.log, "--tz", "Asia/Tokyo")


def test_info_verify_reads_every_message(office: Office) -> None:
    verified = aion.info(office.log, verify=True)
    assert verified["verified"] == {"messages_read": verified["messages"]}
    assert verified == _cli(office.log, "--verify")


def test_info_warnings_are_issued_and_equal_the_command_s(office: Office, tmp_path: Path) -> None:
    """A copy of the log given beside it is read once, as a build reads it: a warning."""
    copy = tmp_path / "copy.mcap"
    shutil.copy(office.log, copy)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        report = aion.info([office.log, copy])
    said = [str(w.message) for w in caught if issubclass(w.category, aion.AionWarning)]
    assert report["warnings"] == said == _cli(office.log, copy)["warnings"]
    assert any("same log" in text for text in said)
    assert caught[0].filename == __file__  # pointing at the caller's line


def test_info_refuses_what_is_not_a_log(office: Office, tmp_path: Path) -> None:
    with pytest.raises(InputError, match="is a map, not a log") as a_map:
        aion.info(office.map)
    assert a_map.value.hint is not None
    assert "aion.Map.load(" in a_map.value.hint
    with pytest.raises(InputError, match="log not found"):
        aion.info(tmp_path / "nope.mcap")
    with pytest.raises(InputError, match="no log given"):
        aion.info([])
    with pytest.raises(InputError, match="verify must be True or False"):
        aion.info(office.log, verify="yes")  # type: ignore[arg-type]
    with pytest.raises(InputError, match="detection_topics") as unknown:
        aion.info(office.log, detection_topics=["/people"])  # type: ignore[call-arg]
    assert "info() takes: logs, log_format" in (unknown.value.hint or "")


def test_the_documented_info_example_runs(tmp_path: Path) -> None:
    """docs/API.md's ``aion.info`` example, as written, in a folder holding the sample log:
    the report it prints from is the command's."""
    import contextlib
    import re

    from tests.doc_blocks import run_blocks

    repo = Path(__file__).resolve().parents[2]
    blocks = re.findall(r"```python\n(.*?)```", (repo / "docs" / "API.md").read_text(), re.S)
    (example,) = [b for b in blocks if "aion.info(" in b]
    (tmp_path / "samples").mkdir()
    shutil.copy(repo / "samples" / "office.mcap", tmp_path / "samples" / "office.mcap")
    scope = run_blocks(tmp_path, "docs/API.md", example)
    with contextlib.chdir(tmp_path):  # the files' paths as given: relative
        assert scope["report"] == _cli(Path("samples") / "office.mcap")
