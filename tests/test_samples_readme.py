"""samples/README.md against samples/regenerate.sh: the command the page says the script runs
is the script's command."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

SAMPLES = Path(__file__).resolve().parents[1] / "samples"


def _options(command: str) -> list[str]:
    """The words of an ``aion simulate`` command after its ``-o PATH`` (the page names the log
    ``samples/office.mcap``, the script ``"$HERE/office.mcap"``), continuation lines joined."""
    words = shlex.split(command.replace("\\\n", " "))
    start = words.index("simulate")
    out = words.index("-o", start)
    return words[start:out] + words[out + 2:]


def test_the_readme_gives_the_command_the_script_runs() -> None:
    """The script's --tf-idle-period became 10 (simulate refuses a parked robot's TF 60 s
    apart: aion build takes a gap over 10 s as its pose unknown), but the page still gave 60,
    so its command, run as written, was refused."""
    page = (SAMPLES / "README.md").read_text()
    documented = re.findall(r"The script runs:\n\n```\n(.*?)```", page, flags=re.S)[0]
    script = (SAMPLES / "regenerate.sh").read_text()
    run = re.findall(r'^"\$BIN/aion" (simulate .*?[^\\])\n', script, flags=re.M | re.S)[0]
    assert _options(documented) == _options(run)
    assert "--tf-idle-period" in _options(run)
