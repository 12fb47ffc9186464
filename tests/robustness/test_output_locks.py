"""Two writers of one output: the second is refused (one ``error:`` line naming the holder,
exit 2) and the output is left to the first. Maps had their lock; ``convert``, ``simulate``,
``export`` and ``report`` wrote unlocked, so two runs raced to rename their outputs into place
(two simulations could leave one run's log beside the other's ground truth, two exports mix
their frames in one folder). They now hold :func:`formats.output_lock.output_lock` too.
"""

from __future__ import annotations

import errno
import json
import os
import shlex
import subprocess
import time
from pathlib import Path

import pytest

from tests.robustness.conftest import AION, Office, aion_env, fails, run
from tests.robustness.test_outputs import tracks_csv

WRITERS: dict[str, tuple[tuple[str, ...], str, bool]] = {
    # name: (arguments, the output, whether it is a folder written into)
    "convert": (("convert", "{csv}", "-o", "{out}"), "x.mcap", False),
    "simulate": (("simulate", "-o", "{out}", "--days", "0.05", "-q"), "x.mcap", False),
    "simulate --scenes": (
        ("simulate", "-o", "{out}", "--scenes", "2", "--days", "0.05", "-q"),
        "scenes",
        True,
    ),
    "export DIR": (("export", "{map}", "--historical", "-o", "{out}"), "scene", True),
    "export .ply": (("export", "{map}", "--historical", "-o", "{out}"), "x.ply", False),
    "export .png": (("export", "{map}", "--historical", "-o", "{out}"), "x.png", False),
    "export .mcap": (("export", "{map}", "--historical", "-o", "{out}"), "x.mcap", False),
    "export .json": (("export", "{map}", "--historical", "-o", "{out}"), "x.json", False),
    "report": (("report", "{map}", "-o", "{out}"), "report", True),
}


def _args(name: str, office: Office, csv: Path, out: Path) -> list[str]:
    names = {"map": office.map, "csv": csv, "out": out}
    return [part.format(**names) for part in WRITERS[name][0]]


CASES = [(name, False) for name in sorted(WRITERS)] + [
    (name, True) for name in sorted(WRITERS) if WRITERS[name][2]
]


@pytest.mark.parametrize(("name", "existing"), CASES)
def test_a_second_writer_of_one_output_is_refused(
    office: Office, tmp_path: Path, name: str, existing: bool
) -> None:
    """While this process holds the output's lock (as a first writer does), the command is
    refused before it writes anything; once the lock is released it runs, and leaves no
    lock behind. ``existing``: a folder written into that exists (its lock is inside it)."""
    from aion_cli.formats.output_lock import output_lock

    _, output, into = WRITERS[name]
    csv = tracks_csv(tmp_path / "tracks.csv")
    out = tmp_path / output
    if existing:
        out.mkdir()
    args = _args(name, office, csv, out)
    with output_lock(out, into=into) as lock:
        result = run(*args)
        fails(result, f"{out} is being written by another process", str(os.getpid()))
        assert str(lock) in result.stderr  # the hint: delete it if no aion is running
        assert not out.exists() or (existing and os.listdir(out) == [lock.name])
    assert sorted(os.listdir(tmp_path)) == sorted(["tracks.csv", *([output] if existing else [])])
    result = run(*args)
    assert result.exit_code == 0, result.stderr
    assert out.exists()
    assert not lock.exists()


def test_two_simulations_of_one_log_keep_the_log_and_its_truth_together(
    tmp_path: Path,
) -> None:
    """Simulation A (seed 1) runs in a subprocess; simulation B (seed 2, --force) starts
    meanwhile and is refused: before, both wrote, and the log of one run could end up beside
    the ground truth of the other. A's log and truth agree."""
    from aion_cli.formats.logs import open_logs

    out = tmp_path / "x.mcap"
    lock = tmp_path / "x.mcap.lock"
    common = ("--days", "1", "-q", "--force")
    proc = subprocess.Popen(
        [str(AION), "simulate", "-o", str(out), "--seed", "1", *common],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=aion_env(),
    )
    try:
        deadline = time.monotonic() + 30
        while not lock.exists() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.005)
        assert lock.exists(), "simulation A took no lock"
        second = run("simulate", "-o", out, "--seed", "2", *common)
        _, err = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err
    fails(second, "being written by another process", str(proc.pid))
    truth = json.loads((tmp_path / "x.mcap.truth.json").read_text())
    assert truth["config"]["seed"] == 1
    with open_logs([out], None) as logset:
        counts = {t.topic: t.count for t in logset.topics}
    det = "/spencer/perception/tracked_persons"
    assert counts[det] == truth["messages"]["detections"]  # the truth of this very log
    assert counts["/tf"] == truth["messages"]["tf"]
    assert not lock.exists()


def test_a_second_simulation_into_the_scenes_folder_the_first_made_is_refused(
    tmp_path: Path,
) -> None:
    """``simulate --scenes 2 -o scenes`` of a missing ``scenes`` took the lock beside it
    (``scenes.lock``) and then made the folder; a second simulation starting after that saw a
    folder and took the lock inside it (``scenes/.aion.lock``), a different file: it ran, and
    the two wrote their logs and truths into one folder. The first now holds the lock inside
    the folder it made as well."""
    from dataclasses import replace

    from aion_cli.errors import OutputLockedError
    from aion_cli.sim.scenario import ScenarioConfig, simulate

    out = tmp_path / "scenes"
    config = replace(ScenarioConfig(days=0.02, seed=3), scenes=2)
    seen: list[BaseException] = []

    def progress(what: str, done: int, total: int) -> None:
        if what.startswith("scene 1/") and not seen:
            assert out.is_dir()
            try:
                simulate(replace(config, seed=4), out)
            except OutputLockedError as exc:
                seen.append(exc)
            else:
                seen.append(AssertionError("the second simulation ran"))

    simulate(config, out, progress)
    assert len(seen) == 1
    assert isinstance(seen[0], OutputLockedError), seen
    assert sorted(os.listdir(tmp_path)) == ["scenes"]
    assert ".aion.lock" not in os.listdir(out)


def test_a_lock_in_a_missing_folder_is_the_missing_folder_error(tmp_path: Path) -> None:
    """A writer that takes its lock first (``run_scene``, the simulator's API the benchmarks
    and ``evaluate office`` call) got "cannot create lock file ...: No such file or
    directory" with a disk-space hint for ``missing/x.mcap``; it is the error every writer
    gives for a missing folder, with its ``mkdir -p`` hint, and nothing is made."""
    from aion_cli.formats.output_lock import output_lock
    from aion_cli.formats.outputs import OutputPathError
    from aion_cli.sim.scenario import ScenarioConfig, load_environment, run_scene

    target = tmp_path / "missing" / "x.mcap"
    with pytest.raises(OutputPathError) as caught, output_lock(target):
        pass
    assert "the folder" in caught.value.message
    assert "does not exist" in caught.value.message
    assert f"mkdir -p {shlex.quote(str(target.parent))}" in (caught.value.hint or "")
    config = ScenarioConfig(days=0.01, seed=1)
    with pytest.raises(OutputPathError, match="does not exist"):
        run_scene(config, load_environment(config), 0, target)
    assert os.listdir(tmp_path) == []


MAP_WRITERS: dict[str, tuple[str, ...]] = {
    "build": ("build", "{log}", "-o", "{out}"),
    "compact": ("compact", "{map}", "-o", "{out}"),
    "merge": ("merge", "{map}", "{copy}", "-o", "{out}"),
}


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux's /proc")
@pytest.mark.parametrize("name", sorted(WRITERS) + sorted(MAP_WRITERS))
def test_an_output_where_no_file_can_be_made_names_the_output_not_its_lock(
    office: Office, tmp_path: Path, name: str
) -> None:
    """``-o /proc/x.aion`` (a folder that exists but takes no new file, even for root) said
    "cannot create lock file /proc/x.aion.lock: No such file or directory", a file the user
    never asked for; it is one line naming the output and the folder that refused it, with
    a hint to write elsewhere, exit 2."""
    csv = tracks_csv(tmp_path / "tracks.csv")
    if name in MAP_WRITERS:
        out = Path("/proc/aion-test.aion")
        copy = office.copy_map(tmp_path / "copy.aion")
        names = {"log": office.log, "map": office.map, "copy": copy, "out": out}
        args = [part.format(**names) for part in MAP_WRITERS[name]]
    else:
        out = Path("/proc") / WRITERS[name][1]
        args = _args(name, office, csv, out)
    result = run(*args)
    fails(result, f"cannot write {'map ' if name in MAP_WRITERS else ''}{out}:")
    assert "files cannot be created in /proc (" in result.stderr
    assert "hint: choose an output path in a folder you can write to" in result.stderr
    assert ".lock" not in result.stderr
    assert not out.exists()


@pytest.mark.parametrize(
    ("code", "hint"),
    [
        (errno.EACCES, "in a folder you can write to"),
        (errno.EROFS, "in a folder you can write to"),
        (errno.ENOSPC, "free some disk space"),
    ],
)
def test_a_refused_lock_names_the_output_and_the_reason(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, code: int, hint: str
) -> None:
    """A folder without write permission, a read-only disk, a full disk: the error names the
    output, its folder and the system's reason, never the lock file; nothing is left."""
    from aion_cli.formats import output_lock as module
    from aion_cli.formats.outputs import OutputPathError

    def refused(lock: Path) -> bool:
        raise OSError(code, os.strerror(code))

    monkeypatch.setattr(module, "_try_create_lock", refused)
    target = tmp_path / "x.mcap"
    with pytest.raises(OutputPathError) as caught, module.output_lock(target):
        pass
    assert caught.value.message == (
        f"cannot write {target}: files cannot be created in {tmp_path} ({os.strerror(code)})"
    )
    assert hint in (caught.value.hint or "")
    assert os.listdir(tmp_path) == []
