"""One simulation run, end to end: environment → people → robot → graph stream → log + truth.

:func:`simulate` is the library entry point behind ``aion simulate``. Everything random is drawn
from ``numpy.random.SeedSequence([seed, scene])`` split into independent streams per component
(schedule, walking, robot, scene graph, sensor noise), and every timestamp derives from the start
date and the tick grid — never the wall clock — so a seed gives byte-identical logs.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import re
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from aion_cli.errors import InputError
from aion_cli.formats.serialize import clean
from aion_cli.sim.agents import AgentSamples, agent_speeds, simulate_agents
from aion_cli.sim.clock import SceneClock
from aion_cli.sim.environment import Environment, load_graph_environment
from aion_cli.sim.graphstream import GraphFrames, StreamConfig, build_frames
from aion_cli.sim.ground_truth import WindowGrid, truth_arrays, write_truth
from aion_cli.sim.messages import detection_msgtype
from aion_cli.sim.office import office_environment
from aion_cli.sim.robot import PatrolConfig, RobotTrack, simulate_robot
from aion_cli.sim.schedule import Rhythm, plan_moves
from aion_cli.sim.sensing import Observations, observe
from aion_cli.sim.writer import write_scene_log

FORMATS: dict[str, tuple[str, str]] = {  # --format -> (LogWriter container, file suffix)
    "mcap": ("mcap", ".mcap"),
    "mcap-ros1": ("mcap-ros1", ".mcap"),
    "bag": ("bag", ".bag"),
    "rosbag2": ("rosbag2-mcap", ""),
    "rosbag2-sqlite3": ("rosbag2-sqlite3", ""),
}

Progress = Callable[[str, int, int], None]

MAX_TICKS = 6_000_000  # ~35 days at 2 Hz: per-tick robot arrays stay below ~300 MB


LAST_START_NS = 9_183_110_400 * 10**9
"""2261-01-01 UTC: the last time aion reads (``engine.mapper.TIME_RANGE_TEXT``)."""
MAX_AGENTS = 1000
"""People per scene at most (each is simulated per tick, in memory)."""
MAX_SCENES = 1000
MIN_PERIOD_S = 0.1
"""The shortest scene-graph, TF or patrol period (seconds)."""


@dataclass(frozen=True)
class ScenarioConfig:
    """Every option of a simulation run (the CLI maps its flags onto these fields)."""

    environment: str = "office"  # "office" or a spark_dsg scene-graph file
    nav_layer: str | None = None  # --nav-layer of a scene-graph file (None: chosen by name)
    days: float = 1.0
    seed: int = 0
    agents: int = 6
    scenes: int = 1
    robot: str = "patrol"  # "patrol" or "fixed"
    frame: str | None = None  # "base_link" | "map"; None: base_link for patrol, map for fixed
    format: str = "mcap"
    detection_type: str = "tracked_persons"
    start: str = "2026-01-05"  # local date (or date and time) the scene starts; a Monday
    utc_offset_h: float = 0.0
    timezone: str | None = None  # a zone with its daylight saving (--tz), else the offset
    rate_hz: float = 2.0
    noise: float = 0.05
    window_s: float = 600.0
    bins: int = 8
    tf_idle_s: float = 10.0
    patrol: PatrolConfig = field(default_factory=PatrolConfig)
    stream: StreamConfig = field(default_factory=StreamConfig)
    rhythm: Rhythm = field(default_factory=Rhythm)

    def _tf_gap_s(self) -> float:
        """Seconds between a parked robot's TF messages: ``tf_idle_s`` in whole sensor ticks
        (at least one), as :func:`aion_cli.sim.writer.write_scene_log` publishes them."""
        if not (self.rate_hz > 0 and self.tf_idle_s > 0):
            return 0.0
        return max(round(self.tf_idle_s * self.rate_hz), 1) / self.rate_hz

    def resolved_frame(self) -> str:
        return self.frame or ("map" if self.robot == "fixed" else "base_link")

    def validate(self) -> None:
        """Raise :class:`InputError` for impossible combinations (before any work is done):
        :func:`aion_cli.sim.scenario_checks.validate_scenario`."""
        from aion_cli.sim.scenario_checks import validate_scenario

        validate_scenario(self)

    def zone_name(self) -> str:
        """The zone the scene's clock follows, as ``aion build --tz`` takes it: ``--tz``'s
        (``Europe/London``, ``UTC+09:00``), else ``--utc-offset``'s fixed offset, else UTC."""
        from aion_cli.timeparse import resolve_zone

        if self.timezone is not None:
            return resolve_zone(self.timezone).name
        minutes = round(abs(self.utc_offset_h) * 60)
        sign = "-" if self.utc_offset_h < 0 else "+"
        return resolve_zone(f"{sign}{minutes // 60:02d}:{minutes % 60:02d}").name

    def recorded(self) -> dict[str, Any]:
        """The config as a scene's ground truth records it (one scene's), with one zone:
        ``timezone`` is :meth:`zone_name` and ``utc_offset_h`` is left out. The two fields
        side by side contradicted each other: with ``--tz Asia/Tokyo`` the file said
        ``utc_offset_h: 0.0`` beside the zone (+9 h), and no single offset is right for a
        zone with daylight saving (London is +1 h in summer)."""
        record: dict[str, Any] = clean(asdict(replace(self, scenes=1)))
        del record["utc_offset_h"]
        record["timezone"] = self.zone_name()
        return record

    def clock(self) -> SceneClock:
        """The scene's local clock (:mod:`aion_cli.sim.clock`)."""
        day, seconds = parse_start(self.start)
        return SceneClock(day, seconds, self.utc_offset_h, self.timezone)


@dataclass(frozen=True)
class SceneResult:
    """Paths and figures of one written scene."""

    log: Path
    truth_npz: Path
    truth_json: Path
    meta: dict[str, Any]


def parse_start(start: str) -> tuple[_dt.date, float]:
    """The local date and the seconds after its midnight of ``start`` (ISO date or datetime)."""
    try:  # spaces around it (a quoted shell variable) are no part of the time, as for --time
        when = _dt.datetime.fromisoformat(" ".join(start.split()))
    except ValueError as exc:
        # the form is right and a field is not (2026-02-29, 25:00): say which, as --time does
        reason = f": {exc}" if re.match(r"\d{4}-\d{2}-\d{2}", start.strip()) else ""
        raise InputError(
            f"bad --start {start!r}{reason}",
            hint="give an ISO date or time, e.g. 2026-01-05T08:00",
        ) from exc
    if when.tzinfo is not None:
        raise InputError(
            f"bad --start {start!r}: give local time without a zone",
            hint="use --tz (or --utc-offset) for the zone",
        )
    seconds = when.hour * 3600.0 + when.minute * 60.0 + when.second + when.microsecond / 1e6
    return when.date(), seconds


def start_ns(start: str, utc_offset_h: float, timezone: str | None = None) -> int:
    """UNIX ns of the ``start`` instant (local time in ``timezone``, or ``utc_offset_h`` hours
    ahead of UTC)."""
    day, seconds = parse_start(start)
    return SceneClock(day, seconds, utc_offset_h, timezone).start_ns()


def load_environment(config: ScenarioConfig) -> Environment:
    """The office, or the walkable part of a scene-graph file."""
    if config.environment == "office":
        return office_environment(max(config.agents, 1))
    return load_graph_environment(Path(config.environment), max(config.agents, 1), config.nav_layer)


_OTHER_FILES = frozenset(
    {".mcap", ".bag", ".db3", ".aion", ".json", ".npz", ".ply", ".pcd", ".png", ".csv", ".txt"}
)
"""Suffixes of logs of another format and of files that are no log at all: ``-o`` ending in
one of them that is not ``--format``'s own is refused rather than given the format's suffix on
top (``apt.bag`` with ``--format mcap`` would become ``apt.bag.mcap``)."""


def scene_paths(output: Path, config: ScenarioConfig) -> list[Path]:
    """Log path of every scene: ``output`` itself for one scene, else ``output/scene_XX``."""
    suffix = FORMATS[config.format][1]
    if config.scenes == 1:
        given = output.suffix.lower()
        if given != suffix and given in _OTHER_FILES:
            # apt.bag with the default --format mcap would be written as apt.bag.mcap, and
            # --format rosbag2 -o apt.mcap as a folder apt.mcap holding apt.mcap.mcap
            formats = [f for f, (_, s) in FORMATS.items() if s == given]
            named = f"-o {output.with_suffix(suffix).name}"
            if suffix:
                hint = f"--format {formats[0]}" if formats else named
            else:
                hint = (f"--format {formats[0]} for a {given} file, or " if formats else "") + (
                    f"{named} for the folder"
                )
            raise InputError(
                f"--format {config.format} writes "
                + (f"a {suffix} log" if suffix else "a rosbag2 folder")
                + f", not -o {output.name}",
                hint=hint,
            )
        if suffix and given != suffix:
            output = output.with_name(output.name + suffix)
        return [output]
    if output.suffix.lower() in _OTHER_FILES and not output.is_dir():
        # a folder named paper.mcap would hold the scenes' logs under a log's name
        raise InputError(
            f"with --scenes {config.scenes}, -o names the folder of the scenes' logs, not a "
            f"file: {output.name}",
            hint=f"-o {output.with_suffix('').name or 'scenes'}/ (it gets scene_00{suffix}, "
            f"scene_01{suffix}, ...)",
        )
    return [output / f"scene_{i:02d}{suffix}" for i in range(config.scenes)]


@dataclass(frozen=True)
class SceneData:
    """Everything one scene simulates, before anything is written (arrays only)."""

    env: Environment
    samples: AgentSamples
    robot: RobotTrack | None
    frames: GraphFrames
    obs: Observations
    t0_ns: int
    dt_ns: int
    n_ticks: int

    @property
    def end_ns(self) -> int:
        return self.t0_ns + (self.n_ticks - 1) * self.dt_ns


def build_scene(
    config: ScenarioConfig, env: Environment, scene: int, progress: Progress | None = None
) -> SceneData:
    """Simulate one scene's people, robot, scene-graph stream and detections."""
    rng_sched, rng_walk, rng_robot, rng_graph, rng_noise = (
        np.random.default_rng(s) for s in np.random.SeedSequence([config.seed, scene]).spawn(5)
    )
    clock = config.clock()
    day, offset_s = clock.day, clock.offset_s
    t0 = clock.start_ns()
    dt_ns = round(1e9 / config.rate_hz)
    dt_s = dt_ns / 1e9
    # ticks k·dt before the wall clock has run ``days`` days: a scene of whole days ends just
    # before midnight (after 23 or 25 hours on a day the clocks change), so the next day's
    # scene (--start a day later) follows it without sharing an instant
    span_s = float(clock.elapsed([offset_s + config.days * 86400.0])[0])
    n_ticks = max(1, int(np.ceil(span_s / dt_s - 1e-9)))
    if progress is not None:
        progress("people", 0, 0)
    days_planned = float(np.ceil((offset_s + config.days * 86400.0) / 86400.0))
    if config.timezone is not None:  # a day of 25 hours moves the last wall day on
        days_planned += 1.0
    moves = plan_moves(
        rng_sched,
        config.agents,
        days_planned,
        day.weekday(),
        env.roles,
        env.n_places,
        config.rhythm,
    )
    moves = replace(moves, t_s=clock.elapsed(moves.t_s))
    samples = simulate_agents(
        env, moves, agent_speeds(rng_walk, config.agents), rng_walk, dt_s, n_ticks
    )
    robot: RobotTrack | None = None
    if config.robot == "patrol":
        if progress is not None:
            progress("robot", 0, 0)
        robot = simulate_robot(env, config.patrol, rng_robot, dt_s, n_ticks, config.days, clock)
    if progress is not None:
        progress("scene graph", 0, 0)
    frames = build_frames(env, robot, config.stream, rng_graph, t0, dt_ns, n_ticks)
    obs = observe(env, samples, robot, config.resolved_frame(), config.noise, rng_noise, dt_ns)
    return SceneData(env, samples, robot, frames, obs, t0, dt_ns, n_ticks)


def run_scene(
    config: ScenarioConfig,
    env: Environment,
    scene: int,
    log_path: Path,
    progress: Progress | None = None,
    overwrite: bool = False,
    lock: bool = True,
) -> SceneResult:
    """Simulate one scene and write its log and ground truth (``overwrite``: replace a log
    and truth files of a previous run; each appears complete or not at all). The log's lock
    (:func:`formats.output_lock.output_lock`) is held across both, so a log and its truth
    always come from one run; ``lock=False``: the caller holds it (:func:`simulate`)."""
    from aion_cli.formats.output_lock import output_lock

    with output_lock(log_path) if lock else contextlib.nullcontext():
        return _write_scene(config, env, scene, log_path, progress, overwrite)


def _write_scene(
    config: ScenarioConfig,
    env: Environment,
    scene: int,
    log_path: Path,
    progress: Progress | None,
    overwrite: bool,
) -> SceneResult:
    """:func:`run_scene` under the lock."""
    data = build_scene(config, env, scene, progress)
    msgtype = detection_msgtype(config.detection_type)
    container = FORMATS[config.format][0]
    report = None if progress is None else (lambda d, t: progress("writing", d, t))
    counts = write_scene_log(
        log_path,
        container,
        env,
        data.frames,
        data.obs,
        data.robot,
        msgtype,
        data.t0_ns,
        data.dt_ns,
        data.n_ticks,
        config.tf_idle_s,
        config.stream.include_mesh,
        config.noise,
        progress=report,
        overwrite=overwrite,
        timezone=config.zone_name(),
    )
    if progress is not None:
        progress("ground truth", 0, 0)
    grid = WindowGrid.covering(data.t0_ns, data.end_ns, config.window_s)
    seen = np.zeros(len(data.samples), dtype=bool)
    seen[data.obs.sample] = True
    arrays = truth_arrays(
        env, data.samples, seen, data.robot, data.frames, grid, config.bins, data.t0_ns, data.dt_ns
    )
    meta = {
        "scene": scene,
        "log": log_path.name,
        "config": config.recorded(),
        "environment": env.name,
        "nav_layer": env.layer or None,
        "environment_notes": list(env.notes),
        "places": env.n_places,
        "start_ns": data.t0_ns,
        "end_ns": data.end_ns,
        "tick_ns": data.dt_ns,
        "frame": config.resolved_frame(),
        "window_s": config.window_s,
        "bins": config.bins,
        "bin_convention": "bin(theta) = floor((theta + pi) / (2 pi / B)) mod B",
        "topics": counts.topics,
        "messages": {"tf": counts.tf, "scene_graph": counts.dsg, "detections": counts.detections},
        "detections": counts.detection_rows,
    }
    npz, js = write_truth(log_path, arrays, meta, overwrite=overwrite)
    return SceneResult(log_path, npz, js, meta)


def simulate(
    config: ScenarioConfig, output: Path, progress: Progress | None = None, overwrite: bool = False
) -> list[SceneResult]:
    """Simulate ``config.scenes`` scenes into ``output`` (a log path, or a folder of scenes),
    holding the output's lock (:func:`formats.output_lock.output_lock`: the one log, or the
    folder of scenes) from the checks to the last truth file: a second ``simulate`` of the
    same output is refused rather than mixing its logs and truth with this one's."""
    from aion_cli.formats.output_lock import output_lock
    from aion_cli.formats.outputs import refuse_current_folder

    config.validate()
    refuse_current_folder(output, "office.mcap" if config.scenes == 1 else "scenes")
    paths = scene_paths(output, config)
    check_outputs(output, paths, FORMATS[config.format][0], overwrite)  # nothing is deleted
    with contextlib.ExitStack() as held:
        several = len(paths) > 1
        lock = held.enter_context(output_lock(output if several else paths[0], into=several))
        env = load_environment(config)
        if several and lock.parent != output:
            output.mkdir(exist_ok=True)  # the folder of the scenes (the one above it exists)
            # its lock was beside it (scenes.lock); a second run would now take the one
            # inside it (scenes/.aion.lock): this run holds that one too
            held.enter_context(output_lock(output, into=True))
        results = []
        for scene, path in enumerate(paths):
            if progress is not None:
                progress(f"scene {scene + 1}/{len(paths)}", 0, 0)
            results.append(run_scene(config, env, scene, path, progress, overwrite, lock=False))
    return results


def check_outputs(output: Path, paths: list[Path], container: str, overwrite: bool) -> None:
    """Refuse ``-o`` and the scene logs' paths and their truth files before anything is
    simulated: a device, FIFO or socket (``-o /dev/null`` too, though ``.mcap`` is appended),
    an existing path without ``overwrite``, or one that is not aion's own log / truth file
    (``--force`` never deletes a folder of other files), and a missing folder above ``-o``.
    :class:`formats.outputs.OutputPathError` (exit 2)."""
    from aion_cli.formats.outputs import OutputPathError, check_output_folder, special_kind
    from aion_cli.formats.writers import check_log_target
    from aion_cli.sim.ground_truth import check_truth_targets

    kind = special_kind(output)
    if kind is not None:
        raise OutputPathError(
            f"{output} is {kind}: aion does not write there",
            hint="choose a path for a new log (or one aion wrote)",
        )
    if len(paths) > 1 and output.exists() and not output.is_dir():
        raise OutputPathError(
            f"{output} is a file, not a folder: --scenes {len(paths)} writes a folder of logs",
            hint="choose a folder path for the scenes",
        )
    if len(paths) > 1 and not output.is_dir():
        check_output_folder(output)  # a new folder of scenes: nothing in it to refuse
        return
    for path in paths:
        check_log_target(path, container, overwrite=overwrite)
        check_truth_targets(path, overwrite)
