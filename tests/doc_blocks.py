"""Running the documents' Python examples as written (docs/API.md, README.md)."""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Any


def run_blocks(folder: Path, source: str, *blocks: str) -> dict[str, Any]:
    """Run the code ``blocks`` in order in one namespace, in ``folder`` as the working
    directory (restored afterwards, also on failure); their variables. ``source`` names the
    document in tracebacks."""
    scope: dict[str, Any] = {}
    with contextlib.chdir(folder):
        for block in blocks:
            exec(compile(block, source, "exec"), scope)
    return scope
