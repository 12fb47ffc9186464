"""A user's own script that imports the package type-checks with mypy from outside the
repository, through the install ``make install`` made. setuptools' default editable install
finds ``aion_cli`` through an import hook, which mypy does not run: ``mypy user.py`` said
"Cannot find implementation or library stub for module named aion_cli" and typed everything
of it ``Any``. The Makefile installs in setuptools' strict editable mode (a tree of links on
``sys.path`` by a plain ``.pth`` line, which mypy follows), and ``py.typed`` is shipped."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

USER_SCRIPT = """\
import aion_cli
import aion_cli.api as api
from aion_cli.formats.writers import LogWriter

reveal_type(api.Map.load)
reveal_type(aion_cli.build)
reveal_type(LogWriter)
"""


@pytest.mark.skipif(
    importlib.util.find_spec("mypy") is None,
    reason="mypy is not installed in this environment (pip install mypy, or the test extra)",
)
def test_mypy_sees_the_installed_package_from_a_users_folder(tmp_path: Path) -> None:
    script = tmp_path / "user.py"
    script.write_text(USER_SCRIPT)
    config = tmp_path / "mypy.ini"
    config.write_text("[mypy]\n")  # no project settings: what a user's bare mypy has
    env = {k: v for k, v in os.environ.items() if k not in ("MYPYPATH", "PYTHONPATH")}
    done = subprocess.run(
        [sys.executable, "-m", "mypy", "--config-file", str(config),
         "--cache-dir", str(tmp_path / "cache"), str(script)],
        capture_output=True, text=True, cwd=tmp_path, env=env, timeout=600, check=False,
    )  # fmt: skip
    said = done.stdout + done.stderr
    assert done.returncode == 0, said
    assert "Cannot find implementation" not in said
    assert "-> aion_cli.api.Map" in said  # Map.load's return type, not Any
    assert 'Revealed type is "def (' in said
    assert "aion_cli.formats.writers.LogWriter" in said
