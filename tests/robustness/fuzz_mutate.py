"""Byte-level mutations for the fuzz worker (``fuzz_worker.py``): truncation, 1-8 random
bytes overwritten, one flipped bit, a span overwritten with junk, a span deleted or duplicated
-- of a byte string, of one file of a log (a file or a rosbag2 folder), or of a map. Maps are
also mutated *inside* the zip (the manifest text, or an array member with its checksum
updated), so the checks behind the zip CRC are reached.
"""

from __future__ import annotations

import json
import random
import shutil
import zipfile
from pathlib import Path

from tests.formats.map_damage import declare_member


def mutate(data: bytes, rng: random.Random) -> bytes:
    """One random structural mutation of ``data``."""
    if not data:
        return bytes([rng.randrange(256)])
    d = bytearray(data)
    kind = rng.randrange(6)
    n = len(d)
    if kind == 0:
        return bytes(d[: rng.randrange(n)])
    if kind == 1:
        for _ in range(rng.randrange(1, 9)):
            d[rng.randrange(n)] = rng.randrange(256)
    elif kind == 2:
        d[rng.randrange(n)] ^= 1 << rng.randrange(8)
    elif kind == 3:
        at = rng.randrange(n)
        span = min(rng.randrange(1, 65), n - at)
        d[at : at + span] = bytes(rng.randrange(256) for _ in range(span))
    elif kind == 4:
        at = rng.randrange(n)
        del d[at : at + rng.randrange(1, 65)]
    else:
        at = rng.randrange(n)
        d[at:at] = d[at : at + rng.randrange(1, 65)]
    return bytes(d)


def _mutant_log(seed: Path, rng: random.Random, work: Path) -> Path:
    """A copy of the seed log (file or rosbag2 folder) with one file mutated."""
    if seed.is_dir():
        target = work / seed.name
        shutil.copytree(seed, target)
        files = sorted(p for p in target.iterdir() if p.is_file())
        victim = rng.choice(files)
        victim.write_bytes(mutate(victim.read_bytes(), rng))
        return target
    target = work / seed.name
    target.write_bytes(mutate(seed.read_bytes(), rng))
    return target


def _rezip(contents: dict[str, bytes], path: Path) -> None:
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_STORED) as zout:
        for name, data in contents.items():
            zout.writestr(name, data)


def mutate_map(seed: Path, rng: random.Random, out: Path) -> None:
    """A mutant map: raw bytes, the manifest text, or an array member whose checksum and size
    in the manifest are updated to match (so the deeper checks run)."""
    kind = rng.randrange(3)
    if kind == 0:
        out.write_bytes(mutate(seed.read_bytes(), rng))
        return
    with zipfile.ZipFile(seed) as zin:
        contents = {name: zin.read(name) for name in zin.namelist()}
    if kind == 1:
        contents["manifest.json"] = mutate(contents["manifest.json"], rng)
    else:
        name = rng.choice(sorted(n for n in contents if n.endswith(".npy")))
        data = mutate(contents[name], rng)
        contents[name] = data
        manifest = json.loads(contents["manifest.json"])
        rec = manifest["members"][name[: -len(".npy")]]
        declare_member(rec, data)
        contents["manifest.json"] = json.dumps(manifest).encode()
    _rezip(contents, out)
