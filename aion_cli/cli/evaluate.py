"""``aion evaluate``: the paper's comparison, predictive accuracy on real data, the FreMEn check.

Every subcommand prints a table on stdout (``--format json`` for scripts) and progress notes on
stderr. The protocols and the exact definition of every number are in ``docs/EVALUATION.md``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from aion_cli.cli.common import (
    AionPath,
    base_frame_option,
    detections_mapping_option,
    graph_topic_option,
    load_config,
    log_format_option,
    map_frame_option,
    quiet_option,
)
from aion_cli.cli.evaluate_columns import (
    ACTIVITY_COLUMNS,
    LINCOLN_ACTIVITY_COLUMNS,
    SCORE_COLUMNS,
    TABLE_I_COLUMNS,
)
from aion_cli.cli.evaluate_data import (
    DATA_DEFAULT_TEXT,
    data_default_text,
    data_folder,
    existing_dir,
)
from aion_cli.cli.output import Column, emit, format_option, num

OFFICE_MAX_DAYS = 34
"""The most --days of evaluate office (and report): what a simulated scene holds at 2 Hz
(``sim.scenario.MAX_TICKS``: its robot is simulated per tick in memory)."""


def _config(path: Path | None) -> Any:
    """``--config FILE`` read as ``aion build`` reads it, else the defaults."""
    from aion_cli.engine.config import ModelConfig

    return load_config(path) or ModelConfig()


def _day(text: str) -> str:
    """``--test DAY`` as given, stripped; an empty one is an error, not the default day."""
    from aion_cli.errors import InputError

    if not text.strip():
        raise InputError("--test names no day", hint="e.g. --test 2017-06-09")
    return text.strip()


@click.group("evaluate", short_help="The paper's comparison, real datasets, held-out logs.")
def evaluate() -> None:
    """Evaluate aion: against a grid Map of Dynamics, on real tracks, FreMEn itself, and your
    own map on your own held-out logs.

    \b
    Examples:
      aion evaluate office --scenes 20            the paper's Table I on the simulated office
      aion evaluate atc --protocol chronological  heading NLL on the real ATC mall tracks
      aion evaluate lincoln                       forecasts on a real multi-day corridor
      aion evaluate door                          FreMEn on a real periodic door signal
      aion evaluate report -o report/             all of it as markdown with PNG plots
      aion evaluate holdout site.aion later.mcap  your map's forecast on your held-out logs
    """


@evaluate.command("atc", short_help="Heading NLL on the real ATC mall tracks.")
@click.option(
    "--data",
    "data_dir",
    metavar="DIR",
    type=AionPath(path_type=Path),
    default=None,
    show_default=data_default_text("atc"),
    help="Folder with atc-1024-H_{train,test}.csv.",
)
@click.option(
    "--protocol",
    type=click.Choice(["random", "chronological"], case_sensitive=False),
    default="random",
    show_default=True,
    help="random: train on the _train files, test each hour's _test file; chronological: "
    "train on 09:00-16:59, predict 17:00-20:59.",
)
@click.option("--radius", type=float, default=1.0, show_default=True,
              help="Association radius (m) between a test detection and an aion entry.")
@click.option("--config", "config_path", metavar="FILE",
              type=AionPath(exists=True, path_type=Path),
              help="TOML model parameters (see aion build --print-config).")
@click.option("--per-hour", is_flag=True,
              help="A table row per model and hour (JSON always holds them, as per_hour).")
@format_option(("table", "json"))
@quiet_option
def atc(
    data_dir: Path | None, protocol: str, radius: float, config_path: Path | None, per_hour: bool,
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

    data = existing_dir(data_folder(data_dir, "atc"), "ATC data")
    result = run_atc(data, protocol, _config(config_path), radius, progress=note)
    for line in result.notes:  # hours without training data (JSON: hours_without_training)
        note(line)
    rows = result.rows if per_hour else result.summary()
    columns = ((Column("hour", "hour"),) if per_hour else ()) + SCORE_COLUMNS
    emit(fmt, rows, columns, json_payload=result.to_dict(),
         title=f"ATC, {protocol} protocol, radius {radius} m")


@evaluate.command("door", short_help="FreMEn on a real periodic door signal.")
@click.option(
    "--data",
    "data_dir",
    metavar="DIR",
    type=AionPath(path_type=Path),
    default=None,
    show_default=data_default_text("fremen_door"),
    help="Folder with training_data.txt and test_{times,data}_k.txt.",
)
@format_option(("table", "json"))
@quiet_option
def door(data_dir: Path | None, fmt: str) -> None:
    """FreMEn on a real periodic door signal: per test week, the mean absolute error of the
    prediction against the static mean's.

    \b
    Example:
      aion evaluate door --format json
    """
    from aion_cli.cli.console import note
    from aion_cli.evaluation.door import run_door

    result = run_door(existing_dir(data_folder(data_dir, "fremen_door"), "door data"))
    note(
        f"FreMEn order {result['fremen_order']} (best day-ahead score); the model itself "
        f"chooses {result['chosen_family']}; strongest periods (h): "
        f"{', '.join(str(p) for p in result['strongest_periods_h'])}; FreMEn beats the "
        f"static mean on {result['fremen_wins']} of {len(result['weeks'])} test weeks"
    )
    columns = (
        Column("week", "test week"),
        Column("samples", "samples", lambda v: f"{v:,}"),
        Column("mae_fremen", "MAE FreMEn", num(4)),
        Column("mae_static", "MAE static", num(4)),
        Column("mae_profile", "MAE profile", num(4)),
        Column("mae_chosen", "MAE chosen", num(4)),
    )
    emit(fmt, result["weeks"], columns, json_payload=result, title="FreMEn door check")


@evaluate.command("lincoln", short_help="Forecasts of a real multi-day corridor.")
@click.option(
    "--data",
    "data_dir",
    metavar="DIR",
    type=AionPath(path_type=Path),
    default=None,
    show_default=data_default_text("lincoln"),
    help="Folder with the Lincoln corridor files (2017-*.txt, 2017-05-31_heading.csv).",
)
@click.option("--radius", type=float, default=1.0, show_default=True,
              help="Association radius (m) between a test detection and an aion entry.")
@click.option("--config", "config_path", metavar="FILE",
              type=AionPath(exists=True, path_type=Path),
              help="TOML model parameters (see aion build --print-config) [default: the "
              "defaults with timezone Europe/London].")
@click.option("--train", "train_days", metavar="DAY,...",
              help="Training days (UTC dates, comma-separated) [default: 2017-05-24, -25, "
              "-26, -31].")
@click.option("--test", "test_day", metavar="DAY", help="The test day [default: 2017-06-09].")
@click.option("--align-05-31", "align", is_flag=True,
              help="Put 2017-05-31 (a file of the corridor in another frame) into the other "
              "training days' frame first; JSON data.DAY.aligned: angle_deg, shift_m, mirror, "
              "onto, overlap_before, overlap_after [default: the files as recorded].")
@format_option(("table", "json"))
@quiet_option
def lincoln(
    data_dir: Path | None, radius: float, config_path: Path | None, train_days: str | None,
    test_day: str | None, align: bool, fmt: str,
) -> None:
    """Forecast a real multi-day corridor: train on four days of May 2017, predict June 9 —
    heading NLL and hourly activity (Spearman, Poisson deviance, MAE) of aion against static,
    hour-of-day and STeF-style grid baselines. --train / --test choose another split of the
    recorded days.

    \b
    Examples:
      aion evaluate lincoln --format json > lincoln.json
      aion evaluate lincoln --train 2017-05-24,2017-05-25 --test 2017-05-26
    """
    from aion_cli.cli.console import note, warn
    from aion_cli.evaluation.lincoln import TEST_DAY, TRAIN_DAYS, run_lincoln
    from aion_cli.evaluation.spread import spread_note

    config = load_config(config_path)
    train: tuple[str, ...] = TRAIN_DAYS
    if train_days is not None:
        train = tuple(d.strip() for d in train_days.split(",") if d.strip())
    result = run_lincoln(
        existing_dir(data_folder(data_dir, "lincoln"), "Lincoln data"), config, radius,
        progress=note,
        train_days=train, test_day=TEST_DAY if test_day is None else _day(test_day), align=align,
    )
    for line in result.warnings:  # a user mistake: shown with -q and --format json too
        warn(line)
    flows = ", ".join(f"{k} {v:,}" for k, v in sorted(result.families["flow"].items()))
    note(f"aion's flow models: {flows}")
    spread = spread_note(result.spread)
    if spread is not None:
        note(spread)
    if fmt == "json":
        emit(fmt, [], (), json_payload=result.to_dict())
        return
    total = int(result.data[result.test]["detections"])
    scored = int(result.headings[0]["detections"]) if result.headings else 0
    emit(fmt, result.headings, SCORE_COLUMNS,
         title=f"Lincoln {result.test}, heading NLL on the {scored:,} test detections with a "
         f"heading (of {total:,}; zone {result.zone})")
    emit(fmt, result.activity, LINCOLN_ACTIVITY_COLUMNS,
         title="Lincoln, hourly activity of the test day (Spearman of the hours' totals, "
         "and of their rates per recorded share)")


@evaluate.command("holdout", short_help="Your map's forecast on your held-out logs.")
@click.argument("map_path", metavar="MAP", type=AionPath(exists=True, path_type=Path))
@click.argument("logs", metavar="LOG...", nargs=-1, required=True,
                type=AionPath(exists=True, path_type=Path))
@click.option("--radius", type=float, default=1.0, show_default=True,
              help="Association radius (m) between a test detection and a map entry.")
@click.option("--detections-topic", "detection_topics", multiple=True, metavar="TOPIC",
              help="Read people from this topic of the test logs (repeatable) [default: as "
              "aion build chooses].")
@map_frame_option("The frame the map's positions are in (TF target of the detections) "
                  "[default: the frame the map records, else map].")
@base_frame_option
@detections_mapping_option
@graph_topic_option
@log_format_option
@click.option("--observed", "observed", multiple=True, metavar="START..END",
              help="A span the test logs' sensor was recording (repeatable; as aion build "
              "--observed, times in the map's zone).")
@click.option("--png", "png", type=AionPath(path_type=Path, dir_okay=False), metavar="FILE",
              help="Also draw the hourly truth and forecasts as a PNG.")
@format_option(("table", "json"))
@quiet_option
def holdout(
    map_path: Path, logs: tuple[Path, ...], radius: float, detection_topics: tuple[str, ...],
    map_frame: str | None, base_frame: str, detections_mapping: Path | None,
    graph_topic: str | None, log_format: str | None, observed: tuple[str, ...],
    png: Path | None, fmt: str,
) -> None:
    """Judge a map's forecast on your own held-out logs: heading NLL of every test
    detection, and the hourly activity of the windows the logs observed (summed over every
    place under a fixed sensor, over the places in the robot's range in a robot's window),
    for aion's forecast against its static rates, its own hour-of-day profile and a uniform
    heading. Build the map from earlier logs, keep later ones back.

    \b
    Examples:
      aion build monday.mcap tuesday.mcap -o site.aion
      aion evaluate holdout site.aion wednesday.mcap
      aion evaluate holdout site.aion wednesday.mcap --format json > wednesday.json
      aion evaluate holdout site.aion wednesday.mcap --png wednesday.png

    Headings: NLL (matched) over the detections within --radius of a map entry, NLL (all)
    with the unmatched ones scored as a uniform heading (log 2pi = 1.838), chi-square the
    mean distance between observed and forecast histograms per 1 m cell and window (lower
    is better; docs/EVALUATION.md defines each). Activity: Spearman of the hours' rates,
    Poisson deviance and MAE of the hours' counts.
    JSON keys: test{detections, with_heading, windows, fixed_sensor_windows, robot_windows,
    window_s, timezone, start_ns, end_ns, observation, detection_topics},
    headings[{model, detections, matched, unmatched, nll_matched, nll_all, chi_square}],
    activity[{model, spearman, poisson_deviance, mae}], hours (each hour's start in the
    map's zone), hourly_series{truth, aion, aion static, hour-of-day profile} (per hour),
    spread_coverage{place_windows, hours}{counts, inside, below, above, pit} (how aion's
    flow_p10..flow_p90 band holds the test counts; pit 0.8 when calibrated:
    docs/EVALUATION.md), notes, warnings (null where a figure has no value: the table's -).
    """
    from aion_cli.build_options import BuildOptions, map_frame_of
    from aion_cli.cli.build import observed_notes, observed_spans
    from aion_cli.cli.console import note, warn
    from aion_cli.evaluation.holdout import run_holdout
    from aion_cli.evaluation.spread import spread_note

    if png is not None:  # a bad target fails before the evaluation runs
        from aion_cli.pictures.render import check_png_target

        check_png_target(png, "--png")
    spans = observed_spans(observed, None, map_path)  # in the map's zone
    opts = BuildOptions(logs=logs, detection_topics=detection_topics,
                        map_frame=map_frame_of(map_frame, map_path), base_frame=base_frame,
                        observed=spans, detections_mapping=detections_mapping,
                        graph_topic=graph_topic, log_format=log_format,
                        # as typed: a span apart from the test logs is warned of, as by build
                        observed_typed=tuple(zip(observed, spans, strict=True)))
    result = run_holdout(map_path, opts, radius, progress=note)
    # spans read across a clock change: noted first, in the JSON's notes too (as build's)
    result.notes[:0] = observed_notes(observed, spans, None, map_path)
    for line in (*result.notes, spread_note(result.spread)):
        if line is not None:
            note(line)
    for line in result.warnings:  # the test logs read in part: shown with -q and json too
        warn(line)
    if png is not None:
        from aion_cli.evaluation.holdout import hourly_picture

        title = f"{map_path.name} on {', '.join(p.name for p in logs)}: detections per hour"
        note(f"wrote {hourly_picture(result, png, title, '--png')}")
    if fmt == "json":
        emit(fmt, [], (), json_payload=result.to_dict())
        return
    test = result.test
    emit(fmt, result.headings, SCORE_COLUMNS,
         title=f"{map_path.name} on {len(logs)} held-out log(s): heading NLL of "
         f"{test['with_heading']:,} detections with a heading")
    if result.activity:
        emit(fmt, result.activity, ACTIVITY_COLUMNS,
             title=f"hourly activity over {test['windows']:,} observed "
             f"window{'' if test['windows'] == 1 else 's'} ({len(result.hours)} "
             f"hour{'' if len(result.hours) == 1 else 's'})")


@evaluate.command("office", short_help="The paper's Table I on the simulated office.")
@click.option("--scenes", type=click.IntRange(1, 200), default=20, show_default=True,
              help="Simulated office scenes (the paper used 20).")
@click.option("--agents", type=click.IntRange(1, 100), default=6, show_default=True,
              help="People per scene (the paper used 6).")
@click.option("--days", type=click.FloatRange(0.1, OFFICE_MAX_DAYS), default=2.0, show_default=True,
              help="Simulated days per scene.")
@click.option("--seed", type=int, default=0, show_default=True,
              help="Random seed of the simulated scenes.")
@click.option("--radius", type=float, default=1.0, show_default=True,
              help="A grid cell takes the nearest aion entry within this radius (m).")
@click.option("--config", "config_path", metavar="FILE",
              type=AionPath(exists=True, path_type=Path),
              help="TOML model parameters (see aion build --print-config).")
@click.option("--keep", "work_dir", metavar="DIR", type=AionPath(path_type=Path),
              help="Keep the simulated logs and maps in this folder.")
@format_option(("table", "json"))
@quiet_option
def office(
    scenes: int, agents: int, days: float, seed: int, radius: float, config_path: Path | None,
    work_dir: Path | None, fmt: str,
) -> None:
    """The paper's Table I: aion against a STeF-style grid on simulated office scenes, with the
    paper's numbers beside ours.

    \b
    Example:
      aion evaluate office --scenes 20 --days 2 --format json > table1.json
    """
    from aion_cli.cli.console import note
    from aion_cli.evaluation.office import run_office, truth_sentence
    from aion_cli.evaluation.office_directions import direction_truth_sentence

    result = run_office(scenes, days, agents, seed, _config(config_path), radius,
                        work_dir=work_dir, progress=note)
    emit(fmt, result.table(), TABLE_I_COLUMNS, json_payload=result.to_dict(),
         title=f"aion vs grid, {scenes} office scene{'' if scenes == 1 else 's'} x "
         f"{agents} {'person' if agents == 1 else 'people'}, {days:g} "
         f"day{'' if days == 1 else 's'} each")
    means = result.truth_means()
    if fmt.lower() == "table" and means:
        click.echo(truth_sentence(means))
    directions = result.directions()
    if fmt.lower() == "table" and directions and directions[0]["scenes"]:
        click.echo(direction_truth_sentence(directions))


@evaluate.command("report")
@click.option("-o", "--output", "out_dir", type=AionPath(path_type=Path), required=True,
              help="Folder for report.md and its PNG plots.")
@click.option("--data", "data_dir", metavar="DIR", type=AionPath(path_type=Path), default=None,
              show_default=DATA_DEFAULT_TEXT,
              help="The shared data folder (atc/, lincoln/, fremen_door/).")
@click.option("--scenes", type=click.IntRange(1, 200), default=20, show_default=True,
              help="Simulated office scenes (as evaluate office).")
@click.option("--days", type=click.FloatRange(0.1, OFFICE_MAX_DAYS), default=2.0, show_default=True,
              help="Simulated days per scene (as evaluate office).")
@click.option("--skip", multiple=True, type=click.Choice(["office", "atc", "lincoln", "door"],
                                                               case_sensitive=False),
              help="Leave a section out (repeatable).")
@quiet_option
def report(
    out_dir: Path, data_dir: Path | None, scenes: int, days: float, skip: tuple[str, ...]
) -> None:
    """Run every protocol and write a markdown report with PNG plots.

    \b
    Example:
      aion evaluate report -o report/ --scenes 20 --days 2
    """
    from aion_cli.cli.console import note
    from aion_cli.evaluation.report import write_report

    path = write_report(out_dir, data_folder(data_dir), scenes=scenes, days=days, skip=set(skip),
                        progress=note)
    note(f"wrote {path}")
