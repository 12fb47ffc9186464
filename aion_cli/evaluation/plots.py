"""PNG plots for the evaluation report (matplotlib with the non-interactive Agg backend).

matplotlib is imported inside each function so importing aion stays fast and headless
machines never need a display.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.formats.outputs import plain_text
from aion_cli.pictures.png_mark import save_marked_png  # marks the pictures as aion's own

F64 = npt.NDArray[np.float64]


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _layered(k: int, n: int) -> dict[str, float]:
    """Line width and marker size of the ``k``-th of ``n`` lines drawn in turn: each narrower
    than the one before, so a model whose values equal an earlier one's (aion's forecast and
    the profile it chose) is drawn inside it and both show, as the legend says."""
    under = n - 1 - k
    return {"linewidth": 1.2 + 0.8 * under, "markersize": 3.0 + 1.5 * under}


def nll_per_hour(rows: list[dict[str, Any]], path: Path, title: str) -> Path:
    """One line per model: mean heading NLL (all detections) against the local hour."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 4))
    models = list(dict.fromkeys(r["model"] for r in rows))
    for k, model in enumerate(models):
        mine = sorted((r for r in rows if r["model"] == model), key=lambda r: r["hour"])
        ax.plot(
            [r["hour"] for r in mine],
            [r["nll_all"] for r in mine],
            marker="o",
            label=model,
            **_layered(k, len(models)),
        )
    ax.axhline(np.log(2 * np.pi), color="grey", linestyle="--", label="uniform (log 2π)")
    ax.set_xlabel("local hour (JST)")
    ax.set_ylabel("heading NLL (nats, lower is better)")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_marked_png(fig, path, dpi=110)
    plt.close(fig)
    return path


def flow_maps_side_by_side(
    grid_xy: F64,
    grid_angle: F64,
    grid_flow: F64,
    aion_xy: F64,
    aion_angle: F64,
    aion_flow: F64,
    path: Path,
    title: str,
) -> Path:
    """The paper's Fig. 4: dominant directions as arrows, grid (left) and aion (right).

    Arrow length follows the flow magnitude normalised by each map's maximum.
    """
    plt = _pyplot()
    fig, axes = plt.subplots(
        1, 2, figsize=(12, 5), sharex=True, sharey=True, layout="constrained"
    )
    arrows = None
    for ax, xy, angle, flow, name in (
        (axes[0], grid_xy, grid_angle, grid_flow, "grid (STeF-style, 1 m)"),
        (axes[1], aion_xy, aion_angle, aion_flow, "aion (nodes and unbound cells)"),
    ):
        ok = np.isfinite(angle) & (flow > 0)
        scale = flow[ok] / max(float(flow[ok].max()), 1e-9) if np.any(ok) else flow[ok]
        arrows = ax.quiver(
            xy[ok, 0], xy[ok, 1], np.cos(angle[ok]) * scale, np.sin(angle[ok]) * scale,
            scale, cmap="viridis", clim=(0.0, 1.0), angles="xy", scale_units="xy",
            scale=1.0, width=0.004,
        )
        ax.set_title(name)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.grid(alpha=0.2)
    axes[0].set_ylabel("y (m)")
    if arrows is not None:
        bar = fig.colorbar(arrows, ax=list(axes), shrink=0.8)
        # a share, no unit: the arrow of the map's busiest entry is 1 m long, the rest as
        # their share ("(colour and arrow length, m)" read as a flow in metres)
        bar.set_label("flow as a share of the map's busiest (colour; arrow length: 1 m = 1)")
    fig.suptitle(title)
    save_marked_png(fig, path, dpi=110)
    plt.close(fig)
    return path


def door_weeks(weeks: list[dict[str, Any]], path: Path, chosen: str | None = None) -> Path:
    """Bars: MAE of FreMEn and of the static mean per test week, and of the family the model
    itself chose (``chosen``, its name; weeks carry ``mae_chosen``) when it is neither: the
    check is FreMEn against the mean, but aion forecasts with its choice, which can do
    better than both (the door's daily shape)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 3.5))
    k = np.array([w["week"] for w in weeks])
    bars = [("mae_fremen", "FreMEn"), ("mae_static", "static mean")]
    if chosen is not None and chosen != "static" and not chosen.startswith("fremen"):
        bars.append(("mae_chosen", f"aion's choice ({chosen})"))
    width = 0.8 / len(bars)
    for i, (key, label) in enumerate(bars):
        offset = (i - (len(bars) - 1) / 2) * width
        ax.bar(k + offset, [w[key] for w in weeks], width=width, label=label)
    ax.set_xticks(k)
    ax.set_xlabel("test week")
    ax.set_ylabel("mean absolute error")
    ax.set_title("FreMEn on the door signal")
    ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), frameon=False)  # not over a bar
    fig.tight_layout()
    save_marked_png(fig, path, dpi=110)
    plt.close(fig)
    return path


def hourly_activity(
    hours: list[int] | list[str],
    series: dict[str, list[float]],
    path: Path,
    title: str,
    xlabel: str = "hour (UTC)",
) -> Path:
    """Detections per hour: the truth as bars, every model's forecast as a line. ``hours``:
    hours of the day (ticks ``HH``) or tick labels as they are; every tick is labelled up to
    24 hours, fewer beyond."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7.5 if len(hours) <= 24 else 11.0, 3.8))
    x = np.arange(len(hours))
    ax.bar(x, series["truth"], color="0.8", label="truth")
    models = [name for name in series if name != "truth"]
    for k, name in enumerate(models):
        ax.plot(x, series[name], marker="o", label=name, **_layered(k, len(models)))
    labels = [f"{h:02d}" if isinstance(h, int) else str(h) for h in hours]
    every = max(1, -(-len(labels) // 24))
    ax.set_xticks(x[::every], labels[::every], rotation=0 if every == 1 else 45)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("detections per hour")
    ax.set_title(plain_text(title))  # holdout's names the map and the logs
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    save_marked_png(fig, path, dpi=110)
    plt.close(fig)
    return path
