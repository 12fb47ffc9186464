"""Where ``aion evaluate`` reads its datasets: ``--data`` as given, else the shared data
folder (``$AION_SHARED_DATA``, else ``../shared/data``), each dataset's folder checked.

Split from :mod:`aion_cli.cli.evaluate`; its commands call these."""

from __future__ import annotations

from pathlib import Path

DATA_ENV = "AION_SHARED_DATA"
DATA_DEFAULT_TEXT = f"${DATA_ENV}, else ../shared/data"


def data_default_text(sub: str) -> str:
    """``--data``'s default in a command's help: the dataset's folder ``sub`` inside the shared
    data folder, whichever it is (the text had read "$AION_SHARED_DATA, else
    ../shared/data/lincoln", as if the variable named the dataset's own folder)."""
    return f"${DATA_ENV}/{sub}, else ../shared/data/{sub}"


def shared_data() -> Path:
    """The shared data folder: ``$AION_SHARED_DATA``, else ``../shared/data`` from the current
    folder (beside a checkout), else ``shared/data`` beside the checkout aion runs from (so
    the examples work from any folder of a development install)."""
    import os

    env = os.environ.get(DATA_ENV)
    if env:
        return Path(env)
    here = Path("../shared/data")
    if here.is_dir():
        return here
    beside = Path(__file__).resolve().parents[3] / "shared" / "data"
    return beside if beside.is_dir() else here


DATA_FILES = {"atc": "atc-1024-*.csv", "lincoln": "2017-*", "fremen_door": "training_data.txt"}
"""A file each dataset's folder holds (``--data`` of ``evaluate atc``, ``lincoln``, ``door``)."""


def data_folder(data_dir: Path | None, sub: str = "") -> Path:
    """``--data`` as given, else the shared data's ``sub`` folder. The shared data folder
    itself given to a command that reads one of its folders (``evaluate report --data``
    takes it) is refused with the folder to give."""
    from aion_cli.errors import InputError

    if data_dir is None:
        return shared_data() / sub if sub else shared_data()
    if sub and (data_dir / sub).is_dir() and not any(data_dir.glob(DATA_FILES[sub])):
        raise InputError(
            f"--data {data_dir} is the shared data folder (it holds {sub}/, not the files "
            "in it): this command reads the dataset's own folder",
            hint=f"give --data {data_dir / sub} (only evaluate report takes the shared folder)",
        )
    return data_dir


def existing_dir(path: Path, what: str) -> Path:
    from aion_cli.errors import InputError

    if path.is_file():  # the dataset's file given for its folder
        raise InputError(
            f"--data {path} is a file: {what} is read from the folder holding its files",
            hint=f"give --data {path.parent}",
        )
    if not path.is_dir():
        raise InputError(
            f"{what} folder not found: {path}",
            hint=f"pass it with --data DIR, or point ${DATA_ENV} at the shared data folder",
        )
    return path
