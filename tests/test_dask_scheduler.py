"""``aion build --scheduler ADDRESS`` where the Dask cluster cannot run the build: an address
nobody answers at, a malformed one, workers without aion. One error line, no map, no hang."""

from __future__ import annotations

import subprocess
import sys
import threading
from pathlib import Path

import pytest

from aion_cli.errors import InputError
from tests.test_parallel_build import _build, _logs


def test_an_unreachable_scheduler_is_a_clear_error(tmp_path: Path) -> None:
    pytest.importorskip("distributed", reason="the dask extra is not installed")
    logs = _logs(tmp_path, [0, 48])
    with pytest.raises(InputError, match="cannot reach the Dask scheduler"):
        _build(logs, tmp_path / "m.aion", 1, scheduler="tcp://127.0.0.1:9")


@pytest.mark.parametrize("address", ["inproc://127.0.0.1/1/1"])
def test_a_malformed_scheduler_address_is_one_line_and_no_traceback(
    tmp_path: Path, address: str
) -> None:
    """A mistyped address was refused, but the half-made Dask client then printed a
    traceback ("Exception ignored in Client.__del__ ... timed out after 10 s") at exit. Here:
    a well-formed address that no scheduler answers at (another process's in-process
    cluster), which the Client refused only after it had started. (Malformed ones are
    refused by their form before a build starts: the test below.)"""
    pytest.importorskip("distributed", reason="the dask extra is not installed")
    from tests.cli.conftest import assert_one_line_error, run_process

    logs = _logs(tmp_path, [0, 48])
    proc = run_process("build", *logs, "-o", tmp_path / "m.aion", "--scheduler", address, "-q")
    assert proc.returncode == 2, proc.stderr
    assert_one_line_error(proc.stderr, "cannot reach the Dask scheduler", address)
    assert not (tmp_path / "m.aion").exists()


def test_workers_that_cannot_import_aion_are_a_clear_error(tmp_path: Path) -> None:
    """A Dask worker without aion died on the first shard's task and the build waited for
    ever; now it is one error line naming the worker, and no map is written."""
    distributed = pytest.importorskip("distributed", reason="the dask extra is not installed")
    from tests.cli.conftest import AION, assert_one_line_error

    logs = _logs(tmp_path, [0, 48])
    without_aion = (  # a worker whose environment has no aion: its import is refused
        "import sys; sys.modules['aion_cli'] = None; sys.modules['formats'] = None; "
        "from distributed.cli.dask_worker import main; main()"
    )
    with distributed.LocalCluster(
        n_workers=0, processes=False, protocol="tcp", host="127.0.0.1", dashboard_address=None,
        scheduler_kwargs={"dashboard_address": ":0"},  # HTTP on a free port, not 8787
    ) as cluster, distributed.Client(cluster, set_as_default=False) as client:
        address = cluster.scheduler_address
        worker = subprocess.Popen(
            [sys.executable, "-c", without_aion, address, "--no-nanny", "--nthreads", "1"],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        try:
            client.wait_for_workers(1, timeout=60)
            proc = subprocess.run(
                [str(AION), "build", *map(str, logs), "-o", str(tmp_path / "m.aion"), "-q",
                 "--scheduler", address],
                capture_output=True, text=True, timeout=60, check=False,
            )
        finally:
            worker.kill()
            worker.wait()
    assert proc.returncode == 1, proc.stderr
    assert_one_line_error(proc.stderr, "1 of the 1 Dask workers", "cannot import aion")
    assert not (tmp_path / "m.aion").exists()


def test_a_scheduler_without_workers_is_a_clear_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A scheduler no worker had joined took the shards and the build waited for ever."""
    distributed = pytest.importorskip("distributed", reason="the dask extra is not installed")
    from aion_cli import dask_build

    monkeypatch.setattr(dask_build, "WORKER_WAIT_S", 1.0, raising=False)
    logs = _logs(tmp_path, [0, 48])
    raised: list[BaseException] = []

    def build(address: str) -> None:
        try:
            _build(logs, tmp_path / "m.aion", 1, scheduler=address)
        except BaseException as exc:  # checked below, in the test's thread
            raised.append(exc)

    with distributed.LocalCluster(
        n_workers=0, processes=False, protocol="tcp", host="127.0.0.1", dashboard_address=None,
        scheduler_kwargs={"dashboard_address": ":0"},  # HTTP on a free port, not 8787
    ) as cluster:
        # in a thread: without the check the build never returns (while the cluster runs)
        thread = threading.Thread(target=build, args=(cluster.scheduler_address,), daemon=True)
        thread.start()
        thread.join(60)
        waited_for_ever = thread.is_alive()
    assert not waited_for_ever
    assert len(raised) == 1, raised
    assert isinstance(raised[0], InputError), raised
    assert "has no workers" in str(raised[0])
    assert not (tmp_path / "m.aion").exists()


MALFORMED = [
    ("garbage", "no port"),
    ("tcp://10.0.0.5", "no port"),
    ("tcp://10.0.0.5:notaport", "port 'notaport' is not a number"),
    ("tcp://10.0.0.5:70000", "port 70000 is not in 1..65535"),
    ("foo://10.0.0.5:8786", "unknown scheme 'foo'"),
    ("tcp://:8786", "no host"),
    ("tcp://10.0 .0.5:8786", "host '10.0 .0.5' is not a host name or IP address"),
]


@pytest.mark.parametrize(("address", "why"), MALFORMED)
def test_a_malformed_scheduler_address_is_refused_whatever_the_shard_count(
    tmp_path: Path, address: str, why: str
) -> None:
    """``--scheduler garbage`` with a build of one shard (one log, no quiet moment to cut it
    at) ran the build and only noted the scheduler 'not contacted'; a typo then went unseen
    until the build was large enough to use it. Now a malformed address is refused before
    any log is read, with one shard as with several (no Dask package needed to say so)."""
    from tests.cli.conftest import assert_one_line_error, run_process

    one = _logs(tmp_path, [0])
    (tmp_path / "two").mkdir()
    for logs in (one, [*one, *_logs(tmp_path / "two", [48])]):
        out = tmp_path / "m.aion"
        proc = run_process("build", *logs, "-o", out, "--scheduler", address, "-q")
        assert proc.returncode == 2, proc.stderr
        assert_one_line_error(
            proc.stderr, f"--scheduler {address} is not a Dask scheduler address: {why}"
        )
        assert "hint: " in proc.stderr
        assert not out.exists()
    with pytest.raises(InputError, match="is not a Dask scheduler address"):
        _build(one, tmp_path / "api.aion", 1, scheduler=address)


@pytest.mark.parametrize(
    "address", ["tcp://10.0.0.5:8786", "10.0.0.5:8786", "tls://dask.example.org:8786",
                "tcp://[::1]:8786", "inproc://127.0.0.1/1/1"],
)
def test_a_well_formed_scheduler_address_is_not_refused_before_it_is_needed(
    address: str,
) -> None:
    from aion_cli.build_options import check_scheduler_address

    check_scheduler_address(address)  # no error: whether it answers is asked when needed


def test_logs_named_relative_to_the_client_are_found_by_workers_elsewhere(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``aion build day0.mcap day1.mcap --scheduler ...`` in the logs' folder: the workers
    run in another working directory, and failed with "no such file or folder: day0.mcap"
    although they saw the logs at the same absolute paths. The tasks now carry absolute
    paths (the logs', ``--graph``'s), and the map is the sequential build's."""
    distributed = pytest.importorskip("distributed", reason="the dask extra is not installed")
    from aion_cli.engine.compare import differences
    from aion_cli.mapquery import load_map
    from tests.cli.logdata import save_graph_file

    folder = tmp_path / "logs"
    folder.mkdir()
    logs = _logs(folder, [0, 48])
    save_graph_file(folder / "dsg.json")
    seq = tmp_path / "seq.aion"
    _build(logs, seq, 1, graph_file=folder / "dsg.json")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)  # the workers' working directory
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None,
        # the scheduler's HTTP server on a free port, not on 8787 (taken: a warning)
        scheduler_kwargs={"dashboard_address": ":0"},
        host="127.0.0.1",
    ) as cluster:
        monkeypatch.chdir(folder)  # the client's: the logs named as there
        names = [Path(p.name) for p in logs]
        report = _build(
            names, tmp_path / "dask.aion", 1, scheduler=cluster.scheduler_address,
            graph_file=Path("dsg.json"),
        )
    assert len(report.workers) == 2  # type: ignore[attr-defined]
    dask = load_map(tmp_path / "dask.aion", writable=True).state
    assert differences(load_map(seq, writable=True).state, dask) == []
