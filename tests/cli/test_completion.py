"""Shell completion of node ids (aion_cli/cli/completion.py), run as a shell runs it: the
installed ``aion`` script with ``_AION_COMPLETE`` and the words of the line in the environment.
The ids offered are the map's own (read back from its graph), in natural order."""

from __future__ import annotations

import os
import shlex
import subprocess
from pathlib import Path

from aion_cli.engine.node_ids import node_labels
from aion_cli.mapquery import load_map
from tests.cli.conftest import AION, Office


def _complete(line: str, shell: str = "bash", cword: str | None = None) -> list[str]:
    """What the shell would offer for the last word of ``line`` (bash: every word's index;
    a line ending in a space completes an empty word)."""
    words = shlex.split(line) + ([""] if line.endswith(" ") else [])
    env = {
        **os.environ,
        "_AION_COMPLETE": f"{shell}_complete",
        "COMP_WORDS": line,
        "COMP_CWORD": cword if cword is not None else str(len(words) - 1),
    }
    done = subprocess.run(
        [str(AION)], capture_output=True, text=True, env=env, timeout=60, check=False
    )
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr
    out = [line for line in done.stdout.splitlines() if line]
    return [item.split(",", 1)[1] for item in out] if shell == "bash" else out


def _word(path: Path) -> str:
    """``path`` as typed on a command line: quoted when it holds a space (pytest's temporary
    folder is under the base temp folder, which may have one)."""
    return shlex.quote(str(path))


def _labels(ids: object) -> set[str]:
    return set(node_labels(ids).tolist())  # type: ignore[arg-type]


def test_plan_completes_the_maps_places(office: Office) -> None:
    graph = load_map(office.map).graph
    assert graph is not None
    places = _labels(graph.places.ids)
    offered = _complete(f"aion plan {_word(office.map)} --from p")
    assert set(offered) == places
    numbers = [int(label[1:]) for label in offered]
    assert numbers == sorted(numbers)  # natural order: p2 before p10
    with_one = _complete(f"aion plan {_word(office.map)} --time now --to p1")
    assert set(with_one) == {p for p in places if p.startswith("p1")}
    assert _complete(f"aion export {_word(office.map)} --path-from p1") == with_one


def test_rooms_and_buildings_are_completed_too(office: Office) -> None:
    graph = load_map(office.map).graph
    assert graph is not None
    rooms = _labels(graph.rooms.ids)
    assert rooms
    names = {"room0", "room1", "room2"}  # the graph's names: any case matches them
    assert set(_complete(f"aion predict {_word(office.map)} --node R")) == rooms | names
    assert set(_complete(f"aion plan {_word(office.map)} --from R")) == rooms | names  # plan too


def test_fish_passes_the_line_up_to_the_current_word(office: Office) -> None:
    line = f"aion plan {_word(office.map)} --from p1"
    offered = _complete(line, shell="fish", cword="p1")
    assert {o.split(",", 1)[-1] for o in offered} == set(_complete(line))


def test_nothing_is_offered_without_a_readable_map(tmp_path: Path) -> None:
    assert _complete("aion plan --from p") == []
    assert _complete(f"aion plan {_word(tmp_path / 'missing.aion')} --from p") == []
    damaged = tmp_path / "damaged.aion"
    damaged.write_bytes(b"PK\x03\x04 not really a map")
    assert _complete(f"aion predict {_word(damaged)} --node p") == []


def test_room_names_are_completed_as_the_commands_read_them(office: Office) -> None:
    """The office graph names its rooms room0 .. room2: offered after the ids, in any case,
    and every one is accepted by plan as the room it names."""
    graph = load_map(office.map).graph
    assert graph is not None
    offered = _complete(f"aion plan {_word(office.map)} --from ROOM")
    assert offered == ["room0", "room1", "room2"]
    assert _complete(f"aion predict {_word(office.map)} --node room1") == ["room1"]
    everything = _complete(f"aion plan {_word(office.map)} --from ")
    assert everything[-3:] == offered  # names after the ids
