"""Damaged scene graphs never reach spark_dsg's unchecked allocations.

spark_dsg resizes a vector to the length field it reads before reading the elements: one
damaged length in a 4.4 KB graph asked for gigabytes (``std::bad_alloc``; or 3.6 GB really
touched). A ``--graph`` ``.sparkdsg`` file is now walked first (``formats.dsg.binary_problem``)
and refused in one line naming the byte; every spark_dsg parse (files and DsgUpdate payloads)
also runs under an address-space budget. Valid graphs (real ones, older versions, a
million-vertex mesh) pass the walk.
"""

from __future__ import annotations

import json
import resource
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from aion_cli.formats import dsg as fdsg
from tests.cli.logdata import build_graph
from tests.formats.dsg_builders import five_places_payload_1_1_2
from tests.robustness.conftest import assert_one_error, run, walk, write_log
from tests.shared_data import SHARED_DATA

DATA = SHARED_DATA / "dsg"
REAL = ["apartment_dsg.json", "mp3d_x8F5xyUWy9e_dsg.json"]


@pytest.fixture(scope="module")
def graph_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The office graph (tests/cli/logdata.py) saved by spark_dsg as .sparkdsg."""
    path = tmp_path_factory.mktemp("graphs") / "office.sparkdsg"
    build_graph().save(str(path), True)
    return path


def _array_headers(data: bytes) -> list[int]:
    """Positions of the 0xdd bytes of a graph spark_dsg wrote: its ARR32 headers (and the
    odd 0xdd inside a value, where a changed "length" is damage as well)."""
    return [i for i in range(len(data) - 5) if data[i] == 0xDD]


def _with_length(data: bytes, at: int, length: int) -> bytes:
    out = bytearray(data)
    out[at + 1 : at + 5] = struct.pack("<I", length)
    return bytes(out)


def test_a_damaged_length_is_refused_in_one_line_before_spark_dsg(
    graph_file: Path, tmp_path: Path
) -> None:
    """The issue's case: the array at byte 772 (a place's attributes) claiming 2^31 - 1
    elements. ``aion build --graph`` and ``aion info`` say where, exit 2."""
    bad = tmp_path / "bad.sparkdsg"
    bad.write_bytes(_with_length(graph_file.read_bytes(), 772, 2**31 - 1))
    log = write_log(tmp_path / "w.mcap", walk(20))
    for args in (("build", log, "--graph", bad, "-o", tmp_path / "m.aion"), ("info", bad)):
        result = run(*args)
        assert result.exit_code == 2, result.stderr
        assert_one_error(
            result.stderr, "cannot read scene-graph file", "it is damaged",
            "the array at byte 772 claims 2,147,483,647 elements but only 3,690 bytes follow",
        )
        assert "bad_alloc" not in result.stderr
    assert not (tmp_path / "m.aion").exists()


@pytest.mark.parametrize("length", [2**31 - 1, 2**26, 2**20])
def test_every_damaged_array_length_is_caught_by_the_walk(graph_file: Path, length: int) -> None:
    """Each of the graph's array lengths set to ``length`` (more than the file holds): the walk
    refuses the file; spark_dsg is not asked (in one case out of 165 the walk finds another
    reading of the bytes, and spark_dsg reads it under the memory budget: 8 MB)."""
    data = graph_file.read_bytes()
    headers = _array_headers(data)
    assert len(headers) > 100
    missed = [at for at in headers if fdsg.binary_problem(_with_length(data, at, length)) is None]
    assert len(missed) <= 1, missed


def test_the_old_3_6_gb_case_stays_small(graph_file: Path, tmp_path: Path) -> None:
    """Length 2^26 at byte 772 made spark_dsg touch 3.6 GB before failing; the refusal now
    happens before any of it (peak RSS of the whole process, in a subprocess)."""
    bad = tmp_path / "bad.sparkdsg"
    bad.write_bytes(_with_length(graph_file.read_bytes(), 772, 2**26))
    peak = _peak_mib(f"from formats.dsg import load_graph; load_graph({str(bad)!r})")
    assert peak["error"].startswith("GraphFileError")
    assert peak["mib"] < 400, peak


def test_a_damaged_payload_is_a_decode_error_within_the_memory_budget(tmp_path: Path) -> None:
    """DsgUpdate payloads are not walked (a log holds thousands); their parse runs under the
    address-space budget instead: the 3.6 GB allocation fails at once."""
    payload = bytes(build_graph().to_binary(False))
    bad = tmp_path / "payload.bin"
    bad.write_bytes(_with_length(payload, 743, 2**26))
    code = (
        "from formats.dsg import decode_dsg, installed_version; "
        f"decode_dsg(open({str(bad)!r}, 'rb').read(), 0, installed_version())"
    )
    peak = _peak_mib(code)
    assert peak["error"].startswith("MessageDecodeError")
    assert "more memory than a payload of its size may take" in peak["error"]
    assert peak["mib"] < 400, peak


def _peak_mib(code: str) -> dict[str, object]:
    """Run ``code`` in a fresh interpreter: its error (type: message) and peak RSS in MiB
    (``VmHWM`` of the new process image; ``ru_maxrss`` would include the forking pytest's)."""
    script = (
        "import json, re\n"
        "try:\n"
        f"    {code}\n"
        "    error = ''\n"
        "except Exception as exc:\n"
        "    error = f'{type(exc).__name__}: {exc}'\n"
        "status = open('/proc/self/status').read()\n"
        "mib = int(re.search(r'VmHWM:\\s+(\\d+) kB', status).group(1)) / 1024\n"
        "print(json.dumps({'error': error, 'mib': mib}))\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120, check=True,
        cwd=Path(__file__).resolve().parents[2],
    )
    result: dict[str, object] = json.loads(proc.stdout.strip().splitlines()[-1])
    return result


def test_the_memory_budget_is_lifted_afterwards() -> None:
    before = resource.getrlimit(resource.RLIMIT_AS)
    with fdsg._memory_budget(1000) as budget:
        inside = resource.getrlimit(resource.RLIMIT_AS)
    assert resource.getrlimit(resource.RLIMIT_AS) == before
    assert budget == fdsg.GRAPH_MEMORY_BASE + 16_000
    assert inside[0] != resource.RLIM_INFINITY
    assert inside[0] <= (before[0] if before[0] != resource.RLIM_INFINITY else inside[0])


@pytest.mark.parametrize("name", REAL)
def test_real_graphs_saved_as_binary_pass_the_walk(name: str, tmp_path: Path) -> None:
    source = DATA / name
    if not source.exists():
        pytest.skip(f"the real scene graphs of ../shared/data/dsg are not here ({source})")
    graph = fdsg.load_dsg_file(source)
    out = tmp_path / "real.sparkdsg"
    graph.save(str(out), True)
    assert fdsg.binary_problem(out.read_bytes()) is None
    loaded = fdsg.load_graph(out)
    assert len(loaded.snapshot.places) == len(fdsg.load_graph(source).snapshot.places)


def test_an_older_version_and_a_big_mesh_pass_the_walk(tmp_path: Path) -> None:
    import spark_dsg

    older = fdsg.spark_header("1.1.2") + five_places_payload_1_1_2()
    assert fdsg.binary_problem(older) is None
    g = build_graph()
    mesh = spark_dsg.Mesh()
    rng = np.random.default_rng(0)
    n = 200_000
    mesh.set_vertices(np.vstack([rng.uniform(0, 10, (3, n)), rng.uniform(0, 1, (3, n))]))
    mesh.set_faces(rng.integers(0, n, (3, 2 * n)).astype(np.int32))
    g.mesh = mesh
    big = tmp_path / "mesh.sparkdsg"
    g.save(str(big), True)
    assert big.stat().st_size > 20 * 1024**2
    assert fdsg.binary_problem(big.read_bytes()) is None
    assert fdsg.load_graph(big).snapshot.mesh is not None


def test_random_damage_is_refused_only_where_the_bytes_are_wrong(
    graph_file: Path, tmp_path: Path
) -> None:
    """The walk accepts when any reading of the bytes is valid, so what it refuses is
    damaged: of 60 random mutants (truncations, flipped bits, junk spans), each refused one
    is a file spark_dsg fails on too (read under the memory budget), or one whose array count
    is larger than the bytes after it -- spark_dsg reads fixed-size arrays (a quaternion's 4
    values) without looking at their count, so it takes a few of those."""
    import random

    import spark_dsg

    from tests.robustness.fuzz_worker import mutate

    rng = random.Random(3)
    data = graph_file.read_bytes()
    refused = 0
    for k in range(60):
        mutant = mutate(data, rng)
        if fdsg.binary_problem(mutant) is None:
            continue
        refused += 1
        path = tmp_path / f"m{k}.sparkdsg"
        path.write_bytes(mutant)
        try:
            with fdsg._native_output_silenced(), fdsg._memory_budget(len(mutant)):
                spark_dsg.DynamicSceneGraph.load(str(path))
        except (RuntimeError, ValueError, IndexError, TypeError, MemoryError):
            continue
        problem = fdsg.binary_problem(mutant)
        assert problem is not None
        assert "claims" in problem, problem  # read by spark_dsg, but a count is wrong
    assert refused > 10


def _graph_as(path: Path, graph_file: Path) -> Path:
    """The office graph at ``path`` in the format its (lower-case) suffix names: JSON for
    ``.json``, else the binary ``graph_file``'s bytes."""
    if path.suffix.lower() == ".json":
        build_graph().save(str(path), False)
    else:
        path.write_bytes(graph_file.read_bytes())
    return path


@pytest.mark.parametrize("suffix", [".SPARKDSG", ".SparkDSG", ".JSON"])
def test_a_graph_file_whose_suffix_is_not_lower_case_reads_as_its_lower_case_twin(
    graph_file: Path, tmp_path: Path, suffix: str
) -> None:
    """spark_dsg picks its reader by the suffix as written and refused ``MAP.SPARKDSG``; aion
    reads such a file like the same bytes under the lower-case name (same places), with
    spark_dsg itself, not the lenient JSON reader, and leaves no temporary link behind."""
    from aion_cli.formats.dsg_files import read_dsg_file

    lower = _graph_as(tmp_path / f"twin{suffix.lower()}", graph_file)
    upper = tmp_path / f"twin-upper{suffix}"
    upper.write_bytes(lower.read_bytes())
    want, got = read_dsg_file(lower), read_dsg_file(upper)
    assert got.reader == want.reader == "spark_dsg"
    assert got.path == upper
    places = [sorted(n.id.value for n in g.graph.get_layer(fdsg.PLACES_LAYER).nodes)
              for g in (want, got)]
    assert places[0] == places[1]
    assert places[0]


@pytest.mark.parametrize(("holds", "named"), [(".json", ".sparkdsg"), (".sparkdsg", ".json")])
def test_a_graph_file_named_as_the_other_format_reads_as_what_it_holds(
    graph_file: Path, tmp_path: Path, holds: str, named: str
) -> None:
    """spark_dsg picks its reader by the suffix: a JSON graph named ``.sparkdsg`` was refused
    as "damaged: byte 0 (0x7b) is not a value", a binary one named ``.json`` as "not JSON
    text (byte 0 is not UTF-8)". Both read as what they hold, with a note saying so."""
    from aion_cli.formats.dsg_files import read_dsg_file

    right = _graph_as(tmp_path / f"right{holds}", graph_file)
    wrong = tmp_path / f"wrong{named}"
    wrong.write_bytes(right.read_bytes())
    want, got = read_dsg_file(right), read_dsg_file(wrong)
    assert got.reader == want.reader == "spark_dsg"
    assert got.format == want.format  # "spark_dsg JSON 1.1.3": what the file holds
    assert got.notes() == [
        f"wrong{named} holds a {want.kind} graph: read as a {holds} file (spark_dsg reads a "
        "graph by its suffix)"
    ]
    assert want.notes() == []
    places = [sorted(n.id.value for n in g.graph.get_layer(fdsg.PLACES_LAYER).nodes)
              for g in (want, got)]
    assert places[0] == places[1]
    assert places[0]
    result = run("info", wrong)
    assert result.exit_code == 0, result.stderr
    assert f"holds a {want.kind} graph" in result.stderr


def test_an_empty_graph_file_is_one_error_with_a_hint(tmp_path: Path) -> None:
    empty = tmp_path / "dsg.json"
    empty.write_bytes(b"")
    result = run("info", empty)
    assert result.exit_code == 2
    assert_one_error(result.stderr, "scene-graph file is empty")
    assert "hint: the graph was not written" in result.stderr


@pytest.mark.parametrize("start", [b"\xef\xbb\xbf", b"\xef\xbb\xbf \n"])
def test_a_json_graph_with_a_byte_order_mark_named_sparkdsg_reads_as_json(
    tmp_path: Path, start: bytes
) -> None:
    """A JSON graph saved with a UTF-8 byte-order mark (as some Windows editors do) reads as
    ``dsg.json``; named ``.sparkdsg`` it was still "damaged: byte 0 (0xef) is not a value"."""
    from aion_cli.formats.dsg_files import read_dsg_file

    right = tmp_path / "right.json"
    build_graph().save(str(right), False)
    marked = start + right.read_bytes()
    (tmp_path / "marked.json").write_bytes(marked)
    wrong = tmp_path / "marked.sparkdsg"
    wrong.write_bytes(marked)
    want, got = read_dsg_file(tmp_path / "marked.json"), read_dsg_file(wrong)
    assert got.kind == "JSON"
    assert got.notes()[0].startswith("marked.sparkdsg holds a JSON graph: read as a .json file")
    places = [sorted(n.id.value for n in g.graph.get_layer(fdsg.PLACES_LAYER).nodes)
              for g in (want, got)]
    assert places[0] == places[1]
    assert places[0]


def test_a_place_far_beyond_the_hash_range_is_named(tmp_path: Path) -> None:
    """One place of the real apartment graph moved to x = 1e300 m (a damaged number): the
    build said "coordinate x=1e+300 (row 0) cannot be hashed", a row of nothing the user
    has, with a hint about the map frame; it now names the place and the graph."""
    from tests.shared_data import real

    graph = json.loads(real("dsg", "apartment_dsg.json").read_text())
    place = next(n for n in graph["nodes"] if n.get("layer") == 3)
    place["attributes"]["position"][0] = 1e300
    label = f"{chr(place['id'] >> 56)}{place['id'] & ((1 << 56) - 1)}"  # p6
    bad = tmp_path / "far.json"
    bad.write_text(json.dumps(graph))
    log = write_log(tmp_path / "w.mcap", walk(20))
    result = run("build", log, "--graph", bad, "-o", tmp_path / "m.aion")
    assert result.exit_code == 2
    assert_one_error(result.stderr, f"coordinate x=1e+300 of scene-graph place {label} ")
    assert "scene graph's positions are damaged" in result.stderr.splitlines()[1]
    assert not (tmp_path / "m.aion").exists()


def test_a_place_at_the_hash_range_s_edge_builds_and_loads_and_one_beyond_is_refused_by_both(
    tmp_path: Path,
) -> None:
    """Build and load agree on a scene graph's places (stop 71): a place 2^20 cells from the
    origin less a quarter cell (the last cell the spatial hash packs, x = 524,287.75 m at
    cell_size 0.5) builds, and its map loads and answers; a quarter cell beyond (524,288.25
    m) is refused by the build, and the map above with its place moved there is refused
    on loading, naming the member (before: loaded, the place never checked)."""
    from aion_cli.engine.spatial_hash import INDEX_MAX
    from aion_cli.formats.mapfile import read_map, write_map
    from tests.shared_data import real

    inside, beyond = (INDEX_MAX + 0.5) * 0.5, (INDEX_MAX + 1.5) * 0.5
    graph = json.loads(real("dsg", "apartment_dsg.json").read_text())
    place = next(n for n in graph["nodes"] if n.get("layer") == 3)
    log = write_log(tmp_path / "w.mcap", walk(20))
    results = {}
    for name, x in (("inside", inside), ("beyond", beyond)):
        place["attributes"]["position"][0] = x
        (tmp_path / f"{name}.json").write_text(json.dumps(graph))
        results[name] = run("build", log, "--graph", tmp_path / f"{name}.json",
                            "-o", tmp_path / f"{name}.aion")
    assert results["inside"].exit_code == 0, results["inside"].stderr
    assert run("predict", tmp_path / "inside.aion", "--historical").exit_code == 0
    assert results["beyond"].exit_code == 2
    assert_one_error(results["beyond"].stderr, f"coordinate x={beyond} of scene-graph place")
    arrays, manifest = read_map(tmp_path / "inside.aion")
    arrays = {k: np.array(v) for k, v in arrays.items()}
    row = int(np.flatnonzero(arrays["graph_places_xyz"][:, 0] == inside)[0])
    arrays["graph_places_xyz"][row, 0] = beyond
    reserved = ("format", "version", "creator", "created", "members")
    write_map(tmp_path / "moved.aion", arrays,
              {k: v for k, v in manifest.items() if k not in reserved})
    result = run("predict", tmp_path / "moved.aion", "--historical")
    assert result.exit_code == 2
    assert_one_error(result.stderr, "map state is inconsistent",
                     f"graph_places_xyz holds {beyond:g} (row {row}), beyond the spatial hash's")
