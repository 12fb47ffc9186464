"""``aion merge`` of fixed-sensor maps (a converted dataset, a tracker on a wall): their
observed windows are global, and the merge adds them for every entry, so an entry only one map
holds counts as observed-empty over the other's windows, as one build of both logs counts it.
The merge is then exact, and must not claim approximation (1), which is about what a *robot*
saw empty, nor say "the other map's robot" of maps without one."""

from __future__ import annotations

import json
from pathlib import Path

from tests.cli.conftest import run, run_json

S = 10**9
DAY0 = 1_767_607_200 * S  # 2026-01-05 10:00 UTC


def _log(tmp_path: Path, name: str, day: int, x0: float) -> Path:
    """A person walking along +x for two minutes from ``x0`` on day ``day`` (another place
    each day), converted with the ten minutes the sensor ran."""
    t0 = DAY0 + day * 86_400 * S
    rows = ["t_ns,track_id,x,y,z,heading_rad,speed_mps"]
    rows += [f"{t0 + i * S},{day + 1},{x0 + i * 0.5:.1f},0.0,0.0,0.0,0.5" for i in range(120)]
    src = tmp_path / f"{name}.csv"
    src.write_text("\n".join(rows) + "\n")
    log = tmp_path / f"{name}.mcap"
    start = f"{t0 // S}..{t0 // S + 600}"
    result = run("convert", src, "-o", log, "--observed", start, "-q")
    assert result.exit_code == 0, result.stderr
    return log


def test_merge_of_fixed_sensor_maps_claims_no_robot_approximation(tmp_path: Path) -> None:
    a, b = _log(tmp_path, "mon", 0, 0.0), _log(tmp_path, "tue", 1, 100.0)
    for log in (a, b):
        assert run("build", log, "-o", log.with_suffix(".aion"), "-q").exit_code == 0
    assert run("build", a, b, "-o", tmp_path / "both.aion", "-q").exit_code == 0
    report = run_json(
        "merge", a.with_suffix(".aion"), b.with_suffix(".aion"), "-o", tmp_path / "m.aion",
        "--format", "json", "-q",
    )
    # before: "240 entries are in one map only ...: the windows in which the other map's
    # robot saw them empty are not known (merge approximation 1)"
    assert not any("approximation 1" in n for n in report["notes"]), report["notes"]
    for key in ("--historical", "--time=2026-01-07 10:05"):
        merged, built = (
            json.loads(run("predict", m, key, "--format", "json", "-q").stdout)["entries"]
            for m in (tmp_path / "m.aion", tmp_path / "both.aion")
        )
        assert merged == built  # exact, as the absent note says
