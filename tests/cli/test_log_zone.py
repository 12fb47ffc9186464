"""``aion simulate --tz ZONE`` writes the zone into its log (MCAP, ROS 1 bag, rosbag2);
``aion build`` without ``--tz`` follows it (a note says so) and warns when ``--tz`` names
another: a London scene built in UTC had its summer hours an hour off, without a word."""

from __future__ import annotations

from pathlib import Path

import pytest

from aion_cli.formats.log_zone import declared_zones
from aion_cli.formats.mapfile import read_manifest
from aion_cli.formats.writers import LogWriter
from tests.cli.conftest import run, run_json


@pytest.fixture(scope="module")
def london(tmp_path_factory: pytest.TempPathFactory) -> Path:
    log = tmp_path_factory.mktemp("zone") / "lon.mcap"
    out = run("simulate", "-o", log, "--days", "1", "--robot", "fixed", "--agents", "3",
              "--tz", "Europe/London", "--start", "2026-06-01")
    assert out.exit_code == 0, out.output
    return log


def test_a_build_without_tz_follows_the_zone_the_log_declares(
    london: Path, tmp_path: Path
) -> None:
    assert declared_zones([london]) == {str(london): "Europe/London"}
    out = tmp_path / "a.aion"
    built = run_json("build", london, "-o", out, "--format", "json")
    assert read_manifest(out)["timezone"] == "Europe/London"
    assert any("lon.mcap declares the time zone Europe/London" in n for n in built["notes"])
    assert not built["warnings"]


def test_another_tz_is_kept_with_a_warning(london: Path, tmp_path: Path) -> None:
    out = tmp_path / "b.aion"
    built = run_json("build", london, "-o", out, "--tz", "UTC", "--format", "json")
    assert read_manifest(out)["timezone"] == "UTC"
    (warning,) = [w for w in built["warnings"] if "declares the time zone" in w]
    assert "Europe/London" in warning
    assert "--tz UTC" in warning
    same = run_json("build", london, "-o", tmp_path / "c.aion", "--tz", "Europe/London",
                    "--format", "json")
    assert not [w for w in same["warnings"] if "declares the time zone" in w]
    # GB is a link to Europe/London in the tz database: the warning said the map's local
    # hours were off wherever the two zones' clocks differ, and they differ nowhere
    alias = run_json("build", london, "-o", tmp_path / "d.aion", "--tz", "GB",
                     "--format", "json")
    assert not [w for w in alias["warnings"] if "declares the time zone" in w]


@pytest.mark.parametrize(
    ("container", "name"),
    [("mcap", "a.mcap"), ("mcap-ros1", "a.mcap"), ("bag", "a.bag"),
     ("rosbag2-sqlite3", "a"), ("rosbag2-mcap", "a")],
)  # fmt: skip
def test_every_container_carries_the_zone(tmp_path: Path, container: str, name: str) -> None:
    """A ROS 1 bag and a rosbag2 folder stored no zone (``add_metadata`` said False), so
    ``aion build`` of a bag simulated with --tz followed UTC without a word. Each container
    now declares it: a bag on a latched topic at its first message's time (the log's span is
    its messages' span still), a rosbag2 folder in metadata.yaml's custom_data."""
    from rosbags.highlevel import AnyReader

    path = tmp_path / name
    t0 = 1_780_000_000 * 10**9
    with LogWriter(path, container) as log:
        assert log.add_metadata("aion", {"timezone": "Asia/Tokyo"})
        for k in range(3):
            log.write("/chatter", "std_msgs/msg/String", {"data": f"m{k}"}, t0 + k * 10**9)
    assert declared_zones([path]) == {str(path): "Asia/Tokyo"}
    if container != "mcap-ros1":  # rosbags reads no ROS 1 MCAP
        with AnyReader([path]) as reader:
            assert (reader.start_time, reader.end_time) == (t0, t0 + 2 * 10**9 + 1)
    undeclared = tmp_path / f"plain-{name}"
    with LogWriter(undeclared, container) as log:
        log.write("/chatter", "std_msgs/msg/String", {"data": "m"}, t0)
    assert declared_zones([undeclared]) == {}


@pytest.mark.parametrize(("fmt", "name"), [("bag", "lon.bag"), ("rosbag2", "lon")])
def test_a_simulated_bag_or_rosbag2_round_trips_its_zone(
    tmp_path: Path, fmt: str, name: str
) -> None:
    """``aion simulate --format bag --tz Europe/London`` then ``aion build`` without --tz:
    the map followed UTC silently (a ROS 1 bag or rosbag2 folder held no zone). It follows
    Europe/London with the note the MCAP log gives, and --tz UTC warns."""
    log = tmp_path / name
    out = run("simulate", "-o", log, "--format", fmt, "--days", "1", "--robot", "fixed",
              "--agents", "3", "--tz", "Europe/London", "--start", "2026-06-01", "-q")
    assert out.exit_code == 0, out.output
    built = run_json("build", log, "-o", tmp_path / "a.aion", "--format", "json")
    assert read_manifest(tmp_path / "a.aion")["timezone"] == "Europe/London"
    assert any(f"{name} declares the time zone Europe/London" in n for n in built["notes"])
    assert not built["warnings"]
    if fmt == "bag":  # info says what the bag's extra topic is
        listed = run("info", log).stdout
        assert "/aion/timezone" in listed
        assert "the log's time zone" in " ".join(listed.split())
    utc = run_json("build", log, "-o", tmp_path / "b.aion", "--tz", "UTC", "--format", "json")
    assert read_manifest(tmp_path / "b.aion")["timezone"] == "UTC"
    assert [w for w in utc["warnings"] if "declares the time zone Europe/London" in w]


def test_the_python_api_follows_the_declared_zone_too(london: Path, tmp_path: Path) -> None:
    import warnings

    import aion_cli as aion

    built = aion.build(london, tmp_path / "api.aion")
    assert built.timezone == "Europe/London"
    assert any("declares the time zone Europe/London" in n for n in built.report.notes)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        other = aion.build(london, tmp_path / "utc.aion", tz="UTC")
    assert other.timezone == "UTC"
    assert any("declares the time zone Europe/London" in str(w.message) for w in caught)


def test_an_mcap_cut_before_its_summary_still_declares_its_zone(tmp_path: Path) -> None:
    """A recorder stopped before the summary (the file cut inside its last chunk): the zone
    record before the first message is read without reading the rest of the file; before,
    mcap's fallback read every record and lost the zone at the cut one."""
    path = tmp_path / "cut.mcap"
    t0 = 1_780_000_000 * 10**9
    with LogWriter(path, "mcap") as log:
        log.add_metadata("aion", {"timezone": "Asia/Tokyo"})
        for k in range(2000):
            log.write("/chatter", "std_msgs/msg/String", {"data": f"m{k}" * 50}, t0 + k * 10**6)
    whole = path.read_bytes()
    path.write_bytes(whole[: len(whole) // 2])
    assert declared_zones([path]) == {str(path): "Asia/Tokyo"}
