"""``aion evaluate report``: every protocol in one markdown file with PNG plots.

Sections: the paper's Table I on the simulated office (with the paper's numbers beside ours and
the Fig. 4-style grid vs aion direction maps), heading NLL on ATC under both protocols (with
per-hour NLL curves), forecasts on the multi-day Lincoln corridor (with the hourly activity
plot), and the FreMEn door check. Each section states the command that
reproduces it. Results are also written as JSON beside the markdown.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from aion_cli.evaluation import plots
from aion_cli.evaluation.office_directions import DIRECTION_METRICS
from aion_cli.number_text import fixed, mean_spread

TITLE = "# aion evaluation report"
REPORT_MD, RESULTS_JSON = "report.md", "results.json"
ATC_PNG = "atc_{}_nll.png"
PICTURES = {
    "office": ("office_directions.png",),
    "atc": tuple(ATC_PNG.format(protocol) for protocol in ("random", "chronological")),
    "lincoln": ("lincoln_hourly.png",),
    "door": ("door.png",),
}
"""The files a report writes: its markdown, its JSON and each section's pictures."""


def _num(value: Any, digits: int = 3) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "--"
    return fixed(value, digits) if isinstance(value, float) else f"{value:,}"


def _table(header: list[str], rows: list[list[str]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return lines


def office_section(result: Any, out_dir: Path, scenes: int, days: float) -> list[str]:
    rows = []
    for r in result.table():
        rows.append(
            [r["map_type"], r["data_type"]]
            + [f"{mean_spread(r[m])} ({mean_spread(r['paper_' + m])})" for m in
               ("js", "bhattacharyya", "wasserstein", "circular_correlation")]
        )
    lines = [
        "## The paper's comparison (Table I): aion vs a STeF-style grid",
        "",
        f"`aion evaluate office --scenes {scenes} --days {days:g}` — mean ± std over scenes; "
        "the paper's numbers in parentheses.",
        "",
        *_table(["Map type", "Data type", "JS divergence", "Bhattacharyya", "Wasserstein",
                 "Circular correlation"], rows),
        "",
    ]
    means = result.truth_means()
    if means:
        lines += [
            "Against the simulator's ground truth (all people, seen or not): mean direction JS "
            f"{_num(means['direction_js'])}, mean correlation of predicted and true flow "
            f"{_num(means['flow_correlation'])}. For scale, on the same places and windows: the "
            "previous day's true counts of all people as the forecast correlate "
            f"{_num(means['flow_correlation_previous_day'])}, and each place's true mean at that "
            "hour over all simulated days, the evaluated day included (in-sample), "
            f"{_num(means['flow_correlation_oracle'])}. Against the expected flow (each window's "
            "mean true count over the other scenes, which differ only in their random draws), "
            f"aion's forecast correlates {_num(means['flow_correlation_expected'])}.",
            "",
        ]
    directions = result.directions()
    if directions and directions[0]["scenes"]:
        lines += [
            "Table I says how far the two maps agree, not which is right. Against the truth "
            "instead: each map's direction histogram at each place that became an aion node, "
            "beside the true histogram of every agent over the evaluated day (mean ± std over "
            "scenes; predicted = the mean of the normalised histograms at the evaluated times; "
            "dominant = the angle between the largest bins' centres; entropy normalised to "
            "[0, 1], its error absolute and signed (above 0: flatter than the truth); lower "
            "is better, the bias nearer 0):",
            "",
            *_table(["Map", "JS divergence", "Dominant direction (deg)", "Entropy error",
                     "Entropy bias"],
                    [[r["map"], *(mean_spread(r[m]) for m in DIRECTION_METRICS)]
                     for r in directions]),
            "",
        ]
    sizes = [(s["aion_bytes"], s["grid_bytes"]) for s in result.scenes]
    lines += [
        f"Stored size per scene: aion map file {sum(a for a, _ in sizes) / len(sizes) / 1e6:.2f} "
        f"MB, dense grid {sum(g for _, g in sizes) / len(sizes) / 1e6:.2f} MB.",
        "",
    ]
    if result.figure is not None:
        fig = result.figure
        png = plots.flow_maps_side_by_side(
            fig["centres"], fig["grid"].angle, fig["grid"].flow,
            fig["centres"], fig["aion"].angle, fig["aion"].flow,
            out_dir / PICTURES["office"][0], "Dominant directions, scene 0 (historical)",
        )
        lines += [f"![grid vs aion]({png.name})", ""]
    return lines


def atc_section(results: dict[str, Any], out_dir: Path) -> list[str]:
    lines = ["## Heading NLL on the real ATC mall tracks", ""]
    for protocol, result in results.items():
        lines += [
            f"### Protocol `{protocol}` — `aion evaluate atc --protocol {protocol}`",
            "",
            f"Association radius {result.radius} m; {result.train_detections:,} training "
            "detections; NLL in nats, uniform = log 2π = 1.838.",
            "",
        ]
        rows = [
            [s["model"], _num(s["detections"]), _num(s["unmatched"]), _num(s["nll_matched"]),
             _num(s["nll_all"]), _num(s["chi_square"])]
            for s in result.summary()
        ]
        lines += _table(["model", "detections", "unmatched", "NLL matched", "NLL all", "chi²"],
                        rows)
        # hours without training data (the real data lacks hour 12's), as aion evaluate atc
        # notes them
        for note in result.notes:
            lines += ["", f"Note: {note}."]
        png = plots.nll_per_hour(result.rows, out_dir / ATC_PNG.format(protocol),
                                 f"ATC, {protocol} protocol")
        lines += ["", f"![NLL per hour]({png.name})", ""]
    return lines


def door_section(result: dict[str, Any], out_dir: Path) -> list[str]:
    rows = [
        [str(w["week"]), _num(w["mae_fremen"], 4), _num(w["mae_static"], 4),
         _num(w["mae_profile"], 4), _num(w["mae_chosen"], 4)]
        for w in result["weeks"]
    ]
    png = plots.door_weeks(result["weeks"], out_dir / PICTURES["door"][0], result["chosen_family"])
    return [
        "## FreMEn on the real door signal — `aion evaluate door`",
        "",
        f"FreMEn order {result['fremen_order']} (its best day-ahead score); strongest periods "
        f"(h): {', '.join(str(p) for p in result['strongest_periods_h'])}. FreMEn beats the "
        f"static mean on {result['fremen_wins']} of {len(result['weeks'])} test weeks; the "
        f"model's own choice is `{result['chosen_family']}`.",
        "",
        *_table(["test week", "MAE FreMEn", "MAE static", "MAE profile", "MAE chosen"], rows),
        "",
        f"![door]({png.name})",
        "",
    ]


def lincoln_section(result: Any, out_dir: Path) -> list[str]:
    """Heading NLL and hourly activity on the Lincoln corridor."""
    head = [
        [s["model"], _num(s["detections"]), _num(s["unmatched"]), _num(s["nll_all"]),
         _num(s["chi_square"])]
        for s in result.headings
    ]
    act = [
        [a["model"], _num(a["spearman"]), _num(a.get("spearman_rate")),
         _num(a["poisson_deviance"], 0), _num(a["mae"], 0)]
        for a in result.activity
    ]
    png = plots.hourly_activity(
        result.hours, result.series, out_dir / PICTURES["lincoln"][0],
        "Lincoln corridor, 2017-06-09: detections per hour",
    )
    flows = ", ".join(f"{k} {v:,}" for k, v in sorted(result.families["flow"].items()))
    dirs = ", ".join(f"{k} {v:,}" for k, v in sorted(result.families["direction"].items()))
    return [
        "## Forecasting a real multi-day corridor (Lincoln) — `aion evaluate lincoln`",
        "",
        "Train on 2017-05-24, -25, -26, -31; forecast 2017-06-09. Headings from linked "
        "tracks; NLL in nats (uniform 1.838).",
        "",
        *_table(["model", "detections", "unmatched", "NLL", "chi²"], head),
        "",
        *_table(["model", "Spearman", "Spearman (rates)", "Poisson deviance", "MAE / hour"],
                act),
        "",
        "Spearman ranks the test hours' totals (the issue's measure); Spearman (rates) ranks "
        "them per recorded share of each hour (the last hour was recorded 14 minutes; a model "
        "of one rate has no ranking then: --).",
        "",
        f"aion's flow families: {flows}; direction families: {dirs}.",
        "",
        f"![hourly activity]({png.name})",
        "",
    ]


def write_report(
    out_dir: Path,
    data_dir: Path,
    scenes: int = 20,
    days: float = 2.0,
    skip: set[str] | None = None,
    progress: Callable[[str], None] | None = None,
) -> Path:
    """Run the protocols not in ``skip`` and write ``out_dir/report.md`` (+ PNGs, JSON)."""
    from aion_cli.errors import InputError
    from aion_cli.formats.outputs import check_output_folder

    skip = skip or set()
    sections = ("office", "atc", "lincoln", "door")
    if set(sections) <= skip:
        raise InputError("every section is skipped: the report would be empty",
                         hint=f"leave out at least one --skip of {', '.join(sections)}")
    if not (math.isfinite(days) and days > 0):
        raise InputError(f"--days must be a positive number, got {days!r}",
                         hint="e.g. --days 2 (the default): simulated days per office scene")
    if not out_dir.exists():  # -o report.md: the folder would look like the page
        from aion_cli.exports import refuse_file_name

        refuse_file_name(out_dir)
    wanted = {"atc": "atc", "lincoln": "lincoln", "door": "fremen_door"}
    for section, folder in wanted.items():  # before anything runs or is written
        if section not in skip and not (data_dir / folder).is_dir():
            raise InputError(
                f"{section} data folder not found: {data_dir / folder}",
                hint=f"pass the shared data folder with --data, or --skip {section}",
            )
    check_output_folder(out_dir)  # the report's folder is made, not those above
    names = [REPORT_MD, RESULTS_JSON]
    names += [png for section, pngs in PICTURES.items() if section not in skip for png in pngs]
    if out_dir.is_dir():  # someone's own file under a name the report writes: refused first
        from aion_cli.formats.outputs import check_replaceable

        check_replaceable((out_dir / name for name in names), is_evaluation_file)
    made = not out_dir.exists()
    out_dir.mkdir(exist_ok=True)
    try:
        return _write_sections(out_dir, data_dir, scenes, days, skip, progress)
    except BaseException:
        if made:  # a run that failed (a section's error, Ctrl-C) leaves no folder of its own
            for name in names:
                (out_dir / name).unlink(missing_ok=True)
            if not any(out_dir.iterdir()):
                out_dir.rmdir()
        raise


def _write_sections(
    out_dir: Path,
    data_dir: Path,
    scenes: int,
    days: float,
    skip: set[str],
    progress: Callable[[str], None] | None,
) -> Path:
    """The sections not in ``skip`` run and written into ``out_dir`` (:func:`write_report`)."""
    from aion_cli.evaluation.atc import run_atc
    from aion_cli.evaluation.door import run_door
    from aion_cli.evaluation.office import run_office

    say = progress or (lambda _m: None)
    lines = [TITLE, ""]
    payload: dict[str, Any] = {}
    if "office" not in skip:
        say("office: the paper's comparison")
        office = run_office(scenes=scenes, days=days, progress=say)
        lines += office_section(office, out_dir, scenes, days)
        payload["office"] = office.to_dict()
    if "atc" not in skip:
        results = {}
        for protocol in ("random", "chronological"):
            say(f"ATC: {protocol} protocol")
            results[protocol] = run_atc(data_dir / "atc", protocol, progress=say)
        lines += atc_section(results, out_dir)
        payload["atc"] = {k: v.to_dict() for k, v in results.items()}
    if "lincoln" not in skip:
        from aion_cli.evaluation.lincoln import run_lincoln

        say("Lincoln: forecasting a multi-day corridor")
        lincoln = run_lincoln(data_dir / "lincoln", progress=say)
        lines += lincoln_section(lincoln, out_dir)
        payload["lincoln"] = lincoln.to_dict()
    if "door" not in skip:
        say("FreMEn door check")
        door = run_door(data_dir / "fremen_door")
        lines += door_section(door, out_dir)
        payload["door"] = door
    path = out_dir / REPORT_MD
    path.write_text("\n".join(lines) + "\n")
    from aion_cli.formats.serialize import clean

    (out_dir / RESULTS_JSON).write_text(json.dumps(clean(payload), indent=1))
    return path


def is_evaluation_file(path: Path) -> bool:
    """Whether ``path`` is a file an evaluation report wrote, which a new one may replace: its
    markdown (its title line), its JSON (an object of the report's sections) or a picture
    aion drew."""
    from aion_cli.pictures.png_mark import is_aion_png

    try:
        if path.suffix.lower() == ".png":
            return is_aion_png(path)
        with open(path, "rb") as fh:
            if path.name == REPORT_MD:
                return fh.read(len(TITLE.encode())) == TITLE.encode()
            payload = json.loads(fh.read(1 << 28))
    except (OSError, ValueError):  # unreadable, not JSON (UnicodeDecodeError included)
        return False
    return isinstance(payload, dict) and set(payload) <= set(PICTURES)
