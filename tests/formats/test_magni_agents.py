"""A THÖR-MAGNI file without any ``Helmet_N`` agent (the dataset's people): every agent is
converted as a person, as documented, but now with a note naming them. Before, a file holding
only the robot (``DARKO_Robot``) became a log of one "person" without a word, while a file
with people beside the robot says the robot is skipped."""

from __future__ import annotations

from pathlib import Path

from aion_cli.formats import tracks as ft
from tests.formats.dataset_files import magni_file


def test_no_helmet_agent_is_said(tmp_path: Path) -> None:
    rows = [f"{k / 100:.2f},{k + 1},0.0,0.0,400.0,DARKO_Robot,Robot,map.png,1" for k in range(5)]
    data = ft.read_track_data(magni_file(tmp_path / "robot.csv", rows=rows), "thor-magni")
    assert len(data.batch) == 5
    assert any("no Helmet_N agent" in n and "DARKO_Robot" in n for n in data.notes), data.notes


def test_people_beside_the_robot_say_nothing_of_the_kind(tmp_path: Path) -> None:
    data = ft.read_track_data(magni_file(tmp_path / "m.csv"), "thor-magni")
    assert not any("no Helmet_N agent" in n for n in data.notes)
    assert any("not people, skipped: DARKO_Robot" in n for n in data.notes)
