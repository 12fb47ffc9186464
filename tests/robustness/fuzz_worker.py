"""Mutation fuzzing of aion's readers, run in a subprocess by ``test_fuzz.py``: the targets,
the case loop and the process entry point.

``python -m tests.robustness.fuzz_worker TARGET SEED CASES TIMEOUT SEEDFILE...`` mutates the
valid seed files (or, for ``detections`` and ``dsg``, payloads it builds itself) ``CASES``
times, feeds each mutant to the target, and prints one JSON line: cases tried, how many were
accepted, how many raised a typed aion error, and the failures (any other exception, or a case
that ran longer than ``TIMEOUT`` seconds: a hang). Run by file path it works the same.

The mutants come from ``fuzz_mutate.py`` (random bytes: targets ``logs``, ``detections``,
``dsg``, ``read_map``, ``load_map``) and ``fuzz_fields.py`` (one length, count, time or map
value: targets ``log_fields``, ``payload_fields``, ``map_values``); the mutators the tests use
are importable from here too. ``log_fields`` mutants also go through the command line
(``aion build`` and ``aion info`` in-process: exit 0 or 2 only), and a ``map_values`` mutant
that loads must give finite, non-negative historical flows and forecasts.

A subprocess, because a mutant may make a C++ reader (spark_dsg) allocate without bound: the
worker runs under an address-space limit, so that becomes a MemoryError (which aion must turn
into a typed error) instead of a machine out of memory.
"""

from __future__ import annotations

import json
import random
import resource
import signal
import sys
import tempfile
import traceback
from collections.abc import Callable
from pathlib import Path
from types import FrameType
from typing import Any

import numpy as np

if not __package__:  # run by file path, not with -m: make the ``tests`` package importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from tests.robustness.fuzz_fields import (
    Field,
    _u,
    bag_fields,
    mcap_fields,
    mutate_fields,
    mutate_log_fields,
    mutate_map_values,
    mutate_mcap_chunk,
    payload_fields,
)
from tests.robustness.fuzz_mutate import _mutant_log, mutate, mutate_map

# what the tests take from here (test_fuzz.py, test_graph_files.py), the mutators re-exported
__all__ = [
    "Field",
    "_u",
    "bag_fields",
    "detection_seeds",
    "main",
    "mcap_fields",
    "mutate",
    "mutate_mcap_chunk",
    "payload_fields",
    "run_cases",
]


MEMORY_LIMIT = 3 * 1024**3


class CaseTimeoutError(Exception):
    """A case ran past its time limit."""


def _alarm(signum: int, frame: FrameType | None) -> None:
    raise CaseTimeoutError


# -- targets ---------------------------------------------------------------------------------


def _read_log(path: Path) -> int:
    """open_logs + every message + decoding the first 20: what ``aion build`` reads."""
    from aion_cli.formats.logs import open_logs

    n = 0
    with open_logs([path]) as logset:
        _ = logset.topics, logset.start_ns, logset.end_ns
        for msg in logset.messages():
            if n < 20:
                logset.decode(msg)
            n += 1
    return n


def detection_seeds() -> list[Any]:
    """One RawMessage per fast-decoded type and encoding, with several people each."""
    from aion_cli.formats.raw import RawMessage
    from aion_cli.formats.writers import LogWriter

    person = {
        "track_id": 3,
        "pose": {"pose": {"position": {"x": 1.0, "y": 2.0, "z": 0.0}, "orientation": {"w": 1.0}}},
        "twist": {"twist": {"linear": {"x": 1.0}}},
    }
    header = {"stamp": {"sec": 1_795_420_800, "nanosec": 5}, "frame_id": "map"}
    pose = {"position": {"x": 1.0, "y": 2.0, "z": 0.0}, "orientation": {"w": 1.0}}
    messages = {
        "spencer_tracking_msgs/msg/TrackedPersons": {"header": header, "tracks": [person] * 3},
        "geometry_msgs/msg/PoseArray": {"header": header, "poses": [pose] * 3},
        "people_msgs/msg/People": {
            "header": header,
            "people": [{"name": "a", "position": {"x": 1.0}, "velocity": {"x": 1.0}}] * 3,
        },
        "vision_msgs/msg/Detection3DArray": {
            "header": header,
            "detections": [{"header": header, "bbox": {"center": pose}}] * 2,
        },
    }
    seeds = []
    with tempfile.TemporaryDirectory() as tmp:
        for container, encoding in (("mcap", "cdr"), ("mcap-ros1", "ros1")):
            with LogWriter(Path(tmp) / f"{container}.mcap", container) as writer:
                for msgtype, msg in messages.items():
                    data = writer.serialize(msgtype, msg)
                    seeds.append(RawMessage("/d", msgtype, 1_795_420_800 * 10**9, data, encoding))
    return seeds


def _decode_detections(raw: Any, skip: bool = False) -> int:
    from aion_cli.formats.detections import adapter_for

    adapter = adapter_for(raw.msgtype)
    assert adapter is not None
    frames = adapter.decode([raw, raw], on_error="skip" if skip else "raise")
    return len(frames)


class CliExitError(Exception):
    """The command line exited with a code other than 0 and 2 (an internal error)."""


def _cli(*commands: list[Any]) -> int:
    """Run ``aion`` commands in-process; :class:`CliExitError` unless each exits 0 or 2 (the
    only codes bad input may give). Returns how many exited 0."""
    from click.testing import CliRunner

    from aion_cli.cli.main import cli

    ok = 0
    for args in commands:
        result = CliRunner().invoke(cli, [str(a) for a in args])
        if "CaseTimeoutError" in result.stderr:
            raise CaseTimeoutError
        if result.exit_code not in (0, 2):
            lines = result.stderr.strip().splitlines() or [repr(result.exception)]
            raise CliExitError(f"aion {args[0]} exited {result.exit_code}: {lines[0]}")
        ok += result.exit_code == 0
    return ok


def _query_map(path: Path) -> int:
    """``load_map``, the historical table and the forecasts of a map: flows must be finite and
    >= 0, and so must the forecast flows and variances at the map's last log time and a week
    later, each entry's direction histogram summing to 1 (a mutated ``forecast_priors`` or
    ``temporal_week_sums`` that loads must not give a broken forecast)."""
    from aion_cli.engine.query import historical_table
    from aion_cli.mapquery import load_map
    from aion_cli.timeparse import MAX_TIME_NS

    state = load_map(path).state
    table = historical_table(state)
    flow = np.asarray(table.flow, dtype=np.float64)
    if flow.size and not (np.isfinite(flow).all() and flow.min() >= 0):
        raise ValueError(f"a map that loads gave flows {flow.min()} .. {flow.max()}")
    rows, predictor = state.predictor()
    if rows.size and state.log_time_ns is not None:
        week = 7 * 86_400 * 10**9  # a query's times are bounded (--time): 1900 .. 2261
        last = min(max(state.log_time_ns, 0), MAX_TIME_NS - week)
        for t_ns in (last, last + week):
            pred = predictor.at(t_ns)
            for name in ("flow", "variance"):
                values = np.asarray(getattr(pred, name), np.float64)
                if not (np.isfinite(values).all() and values.min() >= 0):
                    raise ValueError(f"a map that loads forecast {name} {values.min()} .. "
                                     f"{values.max()}")  # fmt: skip
            probs = np.asarray(pred.probabilities, np.float64)
            if not (np.isfinite(probs).all() and np.abs(probs.sum(axis=1) - 1).max() < 1e-9):
                raise ValueError("a map that loads forecast direction histograms not summing to 1")
    return len(table)


def dsg_seed() -> bytes:
    from tests.cli.logdata import build_graph

    return bytes(build_graph().to_binary(False))


def _where(exc: BaseException) -> str:
    """The innermost frame of aion's own code an exception passed through (file:line func)."""
    frames = [f for f in traceback.extract_tb(exc.__traceback__)
              if "/formats/" in f.filename or "/aion_cli/" in f.filename]
    if not frames:
        return "no aion frame"
    f = frames[-1]
    return f"{Path(f.filename).parent.name}/{Path(f.filename).name}:{f.lineno} {f.name}"


def run_cases(
    target: str, seed: int, cases: int, timeout: float, files: list[Path]
) -> dict[str, Any]:
    """Run ``cases`` mutants through ``target``; the summary dict printed as JSON."""
    from aion_cli.errors import AionError

    rng = random.Random(seed)
    step: Callable[[random.Random, Path], Any]
    if target == "logs":

        def step(r: random.Random, work: Path) -> Any:
            return _read_log(_mutant_log(r.choice(files), r, work))

    elif target == "detections":
        from dataclasses import replace

        payloads = detection_seeds()

        def step(r: random.Random, work: Path) -> Any:
            raw = r.choice(payloads)
            return _decode_detections(replace(raw, data=mutate(raw.data, r)))

    elif target == "dsg":
        from aion_cli.formats.dsg import decode_dsg, installed_version

        graph = dsg_seed()
        native = installed_version()

        def step(r: random.Random, work: Path) -> Any:
            # mostly the native version (one spark_dsg load per case); every 8th case the full
            # fallback over older versions (nine loads)
            version = None if r.randrange(8) == 0 else native
            return decode_dsg(mutate(graph, r), 0, version)

    elif target == "log_fields":

        def step(r: random.Random, work: Path) -> Any:
            log = mutate_log_fields(r.choice(files), r, work)
            _read_log(log)
            return _cli(["info", log], ["build", log, "-o", work / "out.aion", "-q"])

    elif target == "payload_fields":
        from dataclasses import replace

        payloads = detection_seeds()

        def step(r: random.Random, work: Path) -> Any:
            raw = r.choice(payloads)
            fields = payload_fields(raw.data, raw.encoding == "cdr")
            mutant = replace(raw, data=mutate_fields(raw.data, fields, r))
            _decode_detections(mutant)
            return _decode_detections(mutant, skip=True)

    elif target == "map_values":

        def step(r: random.Random, work: Path) -> Any:
            out = work / "mutant.aion"
            mutate_map_values(r.choice(files), r, out)
            return _query_map(out)

    elif target in ("read_map", "load_map"):
        from aion_cli.formats.mapfile import read_map
        from aion_cli.mapquery import load_map

        def step(r: random.Random, work: Path) -> Any:
            out = work / "mutant.aion"
            mutate_map(r.choice(files), r, out)
            return read_map(out) if target == "read_map" else load_map(out)

    else:
        raise SystemExit(f"unknown target {target}")

    accepted = typed = 0
    failures: list[str] = []
    signal.signal(signal.SIGALRM, _alarm)
    for case in range(cases):
        with tempfile.TemporaryDirectory() as tmp:
            case_rng = random.Random(rng.getrandbits(64))
            signal.setitimer(signal.ITIMER_REAL, timeout)
            try:
                step(case_rng, Path(tmp))
                accepted += 1
            except AionError:
                typed += 1
            except CaseTimeoutError:
                failures.append(f"case {case}: no result after {timeout} s (hang)")
            except Exception as exc:
                tail = traceback.format_exception(exc)[-3:]
                failures.append(
                    f"case {case}: {type(exc).__name__}: {exc} (raised through {_where(exc)}) | "
                    + "".join(tail)
                )
            finally:
                signal.setitimer(signal.ITIMER_REAL, 0)
    return {
        "target": target,
        "cases": cases,
        "accepted": accepted,
        "typed_errors": typed,
        "failures": failures,
    }


def main(argv: list[str]) -> None:
    target, seed, cases, timeout, *files = argv
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
    summary = run_cases(target, int(seed), int(cases), float(timeout), [Path(f) for f in files])
    sys.stdout.write(json.dumps(summary) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
