"""``aion evaluate``: the paper's comparison, predictive accuracy on real data, the FreMEn check.

Every subcommand prints a table on stdout (``--format json`` for scripts) and progress notes on
stderr. The protocols and the exact definition of every number are in ``docs/EVALUATION.md``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from aion_cli.cli.output import Column, emit, format_option, num

DEFAULT_DATA = Path("../shared/data")


def _default_dir(sub: str) -> Path:
    return DEFAULT_DATA / sub


def _config(path: Path | None) -> Any:
    from aion_cli.engine.config import ModelConfig

    if path is None:
        return ModelConfig()
    return ModelConfig.from_toml_text(path.read_text())


def _existing_dir(path: Path, what: str) -> Path:
    from aion_cli.engine.errors import InputError

    if not path.is_dir():
        raise InputError(f"{what} folder not found: {path}", hint="pass it with --data DIR")
    return path


@click.group("evaluate")
def evaluate() -> None:
    """Evaluate aion: against a grid Map of Dynamics, on real tracks, and FreMEn itself.

    \b
    Examples:
      aion evaluate office --scenes 20            the paper's Table I on the simulated office
      aion evaluate atc --protocol chronological  heading NLL on the real ATC mall tracks
      aion evaluate door                          FreMEn on a real periodic door signal
      aion evaluate report -o report/             all of it as markdown with PNG plots
    """


SCORE_COLUMNS = (
    Column("model", "model", justify="left"),
    Column("detections", "detections", lambda v: f"{v:,}"),
    Column("unmatched", "unmatched", lambda v: f"{v:,}"),
    Column("nll_matched", "NLL (matched)", num(3)),
    Column("nll_all", "NLL (all)", num(3)),
    Column("chi_square", "chi²", num(3)),
)


@evaluate.command("atc")
@click.option(
    "--data",
    "data_dir",
    type=click.Path(path_type=Path),
    default=_default_dir("atc"),
    show_default=True,
    help="Folder with atc-1024-H_{train,test}.csv.",
)
@click.option(
    "--protocol",
    type=click.Choice(["random", "chronological"]),
    default="random",
    show_default=True,
    help="random: train on the _train files, test each hour's _test file; chronological: "
    "train on 09:00-16:59, predict 17:00-20:59.",
)
@click.option("--radius", type=float, default=1.0, show_default=True,
              help="Association radius (m) between a test detection and an aion entry.")
@click.option("--config", "config_path", type=click.Path(exists=True, path_type=Path),
              help="TOML model parameters (see aion build --print-config).")
@click.option("--per-hour", is_flag=True, help="One row per model and hour.")
@format_option(("table", "json"))
def atc(
    data_dir: Path, protocol: str, radius: float, config_path: Path | None, per_hour: bool,
    fmt: str,
) -> None:
    """Heading NLL of aion, aion+graph, aion static, the grid and a time-of-day histogram
    on the real ATC mall tracks.

    \b
    Example:
      aion evaluate atc --protocol chronological --format json > atc.json
    """
    from aion_cli.cli.console import note
    from aion_cli.evaluation.atc import run_atc

    result = run_atc(_existing_dir(data_dir, "ATC data"), protocol, _config(config_path),
                     radius, progress=note)
    rows = result.rows if per_hour else result.summary()
    columns = ((Column("hour", "hour"),) if per_hour else ()) + SCORE_COLUMNS
    emit(fmt, rows, columns, json_payload=result.to_dict(),
         title=f"ATC, {protocol} protocol, radius {radius} m")


@evaluate.command("door")
@click.option(
    "--data",
    "data_dir",
    type=click.Path(path_type=Path),
    default=_default_dir("fremen_door"),
    show_default=True,
    help="Folder with training_data.txt and test_{times,data}_k.txt.",
)
@format_option(("table", "json"))
def door(data_dir: Path, fmt: str) -> None:
    """FreMEn on a real periodic door signal: per test week, the mean absolute error of the
    prediction against the static mean's.

    \b
    Example:
      aion evaluate door --format json
    """
    from aion_cli.cli.console import note
    from aion_cli.evaluation.door import run_door

    result = run_door(_existing_dir(data_dir, "door data"))
    note(
        f"chosen order {result['chosen_order']}; strongest periods (h): "
        f"{', '.join(str(p) for p in result['strongest_periods_h'])}"
    )
    columns = (
        Column("week", "test week"),
        Column("samples", "samples", lambda v: f"{v:,}"),
        Column("mae_fremen", "MAE FreMEn", num(4)),
        Column("mae_static", "MAE static", num(4)),
    )
    emit(fmt, result["weeks"], columns, json_payload=result, title="FreMEn door check")
