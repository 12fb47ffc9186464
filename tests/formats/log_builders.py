"""Small logs for the ``open_logs`` / ``LogSet`` tests (``test_logs.py``: reading well-formed
logs, ``test_logs_bad_input.py``: bad and damaged input): a people / scene-graph / static-TF log
written in any container (``_write``), and a plain MCAP of indexed payloads on two channels with
a chosen chunk compression (``_write_plain_mcap``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from aion_cli.formats.writers import LogWriter, stamp

T0 = 1_700_000_000_000_000_000


def _people(t: int, xs: list[float]) -> dict[str, Any]:
    return {
        "header": {"stamp": stamp(t), "frame_id": "odom"},
        "people": [
            {"name": f"p{i}", "position": {"x": x, "y": 2.0 * i}, "velocity": {"x": 0.5}}
            for i, x in enumerate(xs)
        ],
    }


def _write(path: Path, container: str, offset: int = 0, n: int = 4) -> Path:
    """n people messages every 100 ns, a DSG update every 2nd, one static TF."""
    with LogWriter(path, container) as w:
        w.write(
            "/tf_static",
            "tf2_msgs/TFMessage",
            {"transforms": [{"header": {"frame_id": "map"}, "child_frame_id": "odom"}]},
            T0 + offset,
        )
        for k in range(n):
            t = T0 + offset + 100 * k
            w.write("/people", "people_msgs/People", _people(t, [k, k + 0.5]), t)
            if k % 2 == 0:
                dsg = {"header": {"stamp": stamp(t)}, "layer_contents": bytes([k, 1, 2])}
                w.write("/hydra/backend/dsg", "hydra_msgs/DsgUpdate", dsg, t + 1)
    return path


def _write_plain_mcap(path: Path, compression: str, n: int = 30, chunk_size: int = 2048) -> None:
    """n std_msgs/Empty-typed messages whose payload carries their index; two channels."""
    from mcap.writer import CompressionType, Writer

    with path.open("wb") as f:
        w = Writer(f, chunk_size=chunk_size, compression=CompressionType[compression])
        w.start(profile="ros2")
        schema = w.register_schema("std_msgs/msg/Empty", "ros2msg", b"")
        even = w.register_channel("/even", "cdr", schema)
        odd = w.register_channel("/odd", "cdr", schema)
        for k in range(n):
            payload = b"\x00\x01\x00\x00" + k.to_bytes(4, "little") * 64
            w.add_message(odd if k % 2 else even, T0 + k, payload, T0 + k)
        w.finish()
