"""Where the tests find the workspace's real public data, and how they skip without it.

The data sits in ``../shared/data`` beside a checkout of this workspace (its README lists the
datasets and their licences). A clone elsewhere has none of it: every test that reads it is
marked with :func:`needs` (or calls :func:`require`) and skips with the reason, so ``make
test`` passes anywhere. ``AION_SHARED_DATA=/path/to/data`` points the tests at another copy
(``AION_SHARED_DATA=/nonexistent make test`` runs the suite as a clone without it would).

A few MB of it are copied into ``tests/data`` (same relative paths, licences beside them:
``tests/data/README.md``); :func:`real` prefers the shared copy and falls back to those, so the
readers are tested on real files from any clone.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

#: the real data: ``$AION_SHARED_DATA`` or ``../shared/data`` beside the repository
SHARED_DATA = Path(os.environ.get("AION_SHARED_DATA") or REPO.parent / "shared" / "data")

#: the small real fixtures kept in the repository
FIXTURES = REPO / "tests" / "data"


def shared(*parts: str) -> Path:
    """A path inside the shared data (it may not exist: pair it with :func:`needs`)."""
    return SHARED_DATA.joinpath(*parts)


def absent_reason(path: Path, what: str) -> str:
    return f"{what} ({path}) is not here: the real data of ../shared/data is absent"


def needs(path: Path, what: str) -> pytest.MarkDecorator:
    """Skip the marked test (or module, as ``pytestmark``) when ``path`` does not exist."""
    return pytest.mark.skipif(not path.exists(), reason=absent_reason(path, what))


def require(path: Path, what: str) -> Path:
    """Inside a test or fixture: skip it when ``path`` does not exist, else return it."""
    if not path.exists():
        pytest.skip(absent_reason(path, what))
    return path


def real_path(*parts: str) -> Path:
    """The shared copy of a real file when it exists, else the repository's fixture copy
    (which may not exist either: pair it with :func:`needs` or use :func:`real`)."""
    shared_copy = SHARED_DATA.joinpath(*parts)
    if shared_copy.exists():
        return shared_copy
    fixture = FIXTURES.joinpath(*parts)
    return fixture if fixture.exists() else shared_copy


def real(*parts: str) -> Path:
    """Inside a test: :func:`real_path`, skipping the test when neither copy exists."""
    return require(real_path(*parts), "/".join(parts))


def writable_copy(source: Path, target: Path) -> Path:
    """``target``, a copy of the folder ``source`` that a test may change. The shared data is
    read-only by permission (folders 0555, files 0444) and ``shutil.copytree`` keeps those
    modes: a test that then wrote into its copy passed as root and failed for anyone else."""
    import shutil

    shutil.copytree(source, target, copy_function=shutil.copyfile)
    for path in [target, *target.rglob("*")]:
        path.chmod(0o755 if path.is_dir() else 0o644)
    return target
