"""A mistake in a script is told in the script's terms: the errors of ``aion.build``,
``aion.merge``, ``aion.compact`` and ``Map.save`` about their output and inputs name no
command-line option (before: "give a file path, e.g. -o office.aion", "write the merged map
to a new file with -o", "aion merge A.aion B.aion ... -o OUT.aion"), and the CLI says the
same, still one line with exit code 2."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

import aion_cli as aion
from aion_cli.errors import InputError
from tests.cli.conftest import Office, assert_one_line_error, run

OPTION = re.compile(r"(^|[\s(`'\"])(-{1,2}[a-z]|aion [a-z]+ )")


def _told(call: object) -> InputError:
    with pytest.raises(InputError) as caught:
        call()  # type: ignore[operator]
    return caught.value


def test_api_errors_about_outputs_and_inputs_name_no_cli_option(
    office: Office, tmp_path: Path
) -> None:
    folder = tmp_path / "folder"
    folder.mkdir()
    copy = tmp_path / "copy.aion"
    shutil.copy(office.map, copy)
    m = aion.Map.load(office.map)
    errors = {
        "build into a folder": _told(lambda: aion.build(office.log, folder)),
        "build over its log": _told(lambda: aion.build(office.log, office.log)),
        "merge nothing": _told(lambda: aion.merge([], tmp_path / "w.aion")),
        "merge a folder": _told(lambda: aion.merge([office.map, folder], tmp_path / "w.aion")),
        "merge into an input": _told(lambda: aion.merge([office.map, copy], copy)),
        "merge into a folder": _told(lambda: aion.merge([office.map, copy], folder)),
        "compact onto itself": _told(lambda: aion.compact(copy, copy)),
        "save into a folder": _told(lambda: m.save(folder)),
    }
    for what, error in errors.items():
        assert error.hint, what
        assert not OPTION.search(f"{error.message} {error.hint}"), (what, error.hint)


def test_the_cli_says_the_same_in_one_line(office: Office, tmp_path: Path) -> None:
    copy = tmp_path / "copy.aion"
    shutil.copy(office.map, copy)
    result = run("merge", office.map, copy, "-o", copy)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "is one of the input maps")
    assert "hint: write the merged map to a new file" in result.stderr.splitlines()
