"""Maps do not depend on the machine's number of cores (docs/ROBUSTNESS.md, reproducibility).

numpy's ``@`` goes to OpenBLAS, which splits a large product over its threads; where the split
changes the order of the additions, a result's last bits differ between a 1-core and a 2-core
machine, and where those bits decide something (κ's hashed sample of rows,
``direction_prior.sample_rows``) the map differs. Each case runs in fresh processes with
OpenBLAS (and OpenMP) at one thread and at two, which is all that differs between them."""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np

from aion_cli.engine.temporal.direction_prior import MAX_ENTRIES
from tests.robustness.conftest import run

SAMPLE = Path(__file__).resolve().parents[2] / "samples" / "office.mcap"

_SAMPLES = """
import hashlib, sys
import numpy as np
from aion_cli.engine.temporal.direction_prior import MAX_ENTRIES, sample_rows
rng = np.random.default_rng(0)
for _ in range(200):
    n, b = int(rng.integers(MAX_ENTRIES + 1, 60_000)), int(rng.choice([8, 12, 16]))
    shares = rng.dirichlet(np.ones(b), n)
    counts = rng.integers(0, 5, (n, b)).astype(np.float64)
    keep = sample_rows(counts, MAX_ENTRIES, shares)
    print(n, b, hashlib.sha1(keep.tobytes()).hexdigest())
"""

_BUILD = """
import sys
import aion_cli.engine.temporal.direction_prior as direction_prior
from aion_cli.cli.entry import main
real = direction_prior.sample_rows
def counted(counts, about, shares=None):
    print("sampled", counts.shape[0], counts.shape[1], file=sys.stderr)
    return real(counts, about, shares)
direction_prior.sample_rows = counted
sys.argv = ["aion", *sys.argv[1:]]
sys.exit(main())
"""


def _python(code: str, threads: int, *args: str | Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "TZ": "UTC"}
    for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        env[name] = str(threads)
    done = subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True,
                          text=True, env=env, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    return done


def _members(path: Path) -> dict[str, str]:
    """Every member's digest, the manifest's without its ``created`` time."""
    out = {}
    with zipfile.ZipFile(path) as z:
        for name in z.namelist():
            data = z.read(name)
            if name == "manifest.json":
                manifest = json.loads(data)
                del manifest["created"]
                data = json.dumps(manifest, sort_keys=True).encode()
            out[name] = hashlib.sha256(data).hexdigest()
    return out


def _fixed_sensor_log(folder: Path) -> Path:
    """Two days of a fixed sensor over 100 x 100 m: 20 people an hour, each walking 40 s in a
    straight line at 1.2 m/s (canonical CSV, then ``aion convert``): some 8,000 cells, so
    every day close samples κ's and κ_t's rows (more than ``MAX_ENTRIES`` tell)."""
    rng = np.random.default_rng(5)
    n, steps = 2 * 24 * 20, 40
    start = 1_767_571_200 + np.sort(rng.integers(0, 2 * 86_400, n))  # 2026-01-05 UTC
    origin = rng.uniform(0.0, 100.0, (n, 2))
    heading = rng.uniform(-np.pi, np.pi, n)
    walked = 1.2 * np.arange(steps)
    rows = np.column_stack([
        ((start[:, None] + np.arange(steps)) * 10**9).ravel(),
        np.repeat(np.arange(n), steps),
        (origin[:, :1] + np.cos(heading)[:, None] * walked).ravel(),
        (origin[:, 1:] + np.sin(heading)[:, None] * walked).ravel(),
        np.ones(n * steps),
        np.repeat(heading, steps),
        np.full(n * steps, 1.2),
    ])
    rows = rows[np.argsort(rows[:, 0], kind="stable")]
    csv = folder / "tracks.csv"
    np.savetxt(csv, rows, fmt=["%d", "%d", "%.3f", "%.3f", "%.1f", "%.4f", "%.1f"],
               delimiter=",", header="t_ns,track_id,x,y,z,heading_rad,speed_mps", comments="")
    log = folder / "sensor.mcap"
    result = run("convert", csv, "-o", log, "-q")
    assert result.exit_code == 0, result.stderr
    return log


def test_kappa_samples_the_same_rows_with_one_or_two_blas_threads() -> None:
    """``sample_rows`` on random parent shares of 200 sizes (8, 12 and 16 bins) keeps the
    same rows whichever number of threads OpenBLAS has: its hash reads one float per row,
    which a matrix-vector product computed with its last bits depending on how the rows were
    split over the threads (before, 2 of these 200 sizes chose other rows at two threads)."""
    one, two = (_python(_SAMPLES, threads).stdout.splitlines() for threads in (1, 2))
    assert len(one) == 200
    assert one == two


def test_maps_are_byte_identical_with_one_or_two_blas_threads(tmp_path: Path) -> None:
    """The bundled office log and a two-day fixed-sensor log (with 8 direction bins, and
    with 12), built in fresh processes with one and with two BLAS threads, give maps whose
    every member is the same to the byte (the manifest apart from its ``created`` time);
    κ's rows were sampled from more than ``MAX_ENTRIES`` rows, enough for OpenBLAS to split
    a product over its threads."""
    log = _fixed_sensor_log(tmp_path)
    printed = run("build", "--print-config")
    assert printed.exit_code == 0, printed.stderr
    twelve = tmp_path / "twelve.toml"
    twelve.write_text(printed.stdout.replace("\nbins = 8\n", "\nbins = 12\n"))
    builds = {"office": (SAMPLE,), "sensor": (log,), "sensor12": (log, "--config", twelve)}
    built = {}
    for threads in (1, 2):
        for name, args in builds.items():
            out = tmp_path / f"{name}-{threads}.aion"
            done = _python(_BUILD, threads, "build", *args, "-o", out, "-q")
            if name != "office":
                sampled = [line.split() for line in done.stderr.splitlines()
                           if line.startswith("sampled")]
                assert sampled
                assert max(int(s[1]) for s in sampled) > 2 * MAX_ENTRIES
                assert {int(s[2]) for s in sampled} == {12 if name == "sensor12" else 8}
            built[threads, name] = _members(out)
    for name in builds:
        assert built[1, name] == built[2, name], name
