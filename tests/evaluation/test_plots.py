"""The evaluation report's plots, read back from their matplotlib artists: every model the
legend names can be seen, the legend covers no data, and the direction maps say what their
axes and colours are."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.evaluation import plots


@pytest.fixture
def drawn(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """The figures the plots are saved from (kept open: the plots close them after saving)."""
    figures: list[Any] = []
    save = plots.save_marked_png

    def keep(fig: Any, path: Any, **options: Any) -> None:
        figures.append(fig)
        save(fig, path, **options)

    monkeypatch.setattr(plots, "save_marked_png", keep)
    return figures


def _lines_hidden_under_others(ax: Any) -> list[str]:
    """Labels of lines drawn under a later line with the same points, at least as wide and
    with markers at least as large: nothing of them shows."""
    lines = [ln for ln in ax.get_lines() if not ln.get_label().startswith("_")]
    hidden = []
    for k, low in enumerate(lines):
        for high in lines[k + 1 :]:
            same = np.array_equal(low.get_xydata(), high.get_xydata())
            if (
                same
                and high.get_linewidth() >= low.get_linewidth()
                and high.get_markersize() >= low.get_markersize()
            ):
                hidden.append(str(low.get_label()))
    return hidden


def test_equal_forecasts_stay_visible_in_the_hourly_plot(tmp_path: Path, drawn: list[Any]) -> None:
    """On the Lincoln corridor aion's forecast equals the hour-of-day profile's and its static
    rates the static model's: drawn alike, one line covered the other, and the legend named
    two models that could not be seen."""
    truth = [10.0, 40.0, 20.0]
    series = {"truth": truth, "aion": [12.0, 35.0, 22.0], "aion static": [20.0, 20.0, 20.0],
              "profile": [12.0, 35.0, 22.0], "static": [20.0, 20.0, 20.0]}
    plots.hourly_activity([9, 10, 11], series, tmp_path / "h.png", "t")
    (ax,) = drawn[-1].axes
    assert _lines_hidden_under_others(ax) == []


def test_equal_models_stay_visible_in_the_nll_plot(tmp_path: Path, drawn: list[Any]) -> None:
    """On ATC aion's NLL per hour equals its static model's (the green line hid the blue)."""
    rows = [{"model": m, "hour": h, "nll_all": v}
            for m, vals in (("aion", (1.3, 1.4)), ("aion static", (1.3, 1.4)),
                            ("grid", (1.5, 1.6)))
            for h, v in zip((9, 10), vals, strict=True)]
    plots.nll_per_hour(rows, tmp_path / "n.png", "t")
    (ax,) = drawn[-1].axes
    assert _lines_hidden_under_others(ax) == []


def test_the_door_legend_covers_no_bar(tmp_path: Path, drawn: list[Any]) -> None:
    """The legend sat in the upper centre, over the bars of the middle weeks."""
    weeks = [{"week": k, "mae_fremen": 0.17, "mae_static": 0.19} for k in range(1, 10)]
    plots.door_weeks(weeks, tmp_path / "d.png")
    fig = drawn[-1]
    (ax,) = fig.axes
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)  # the plot closed its figure after saving it
    canvas.draw()
    renderer = canvas.get_renderer()
    legend = ax.get_legend().get_window_extent(renderer)
    bars = [p.get_window_extent(renderer) for p in ax.patches]
    assert bars
    assert not [b for b in bars if b.overlaps(legend)]
    assert [t.get_text() for t in ax.get_xticklabels()] == [str(k) for k in range(1, 10)]


@pytest.mark.parametrize(("chosen", "bars"), [("shape", 3), ("profile", 3), ("fremen2", 2),
                                              ("static", 2), (None, 2)])
def test_the_door_plot_shows_the_models_own_choice(
    tmp_path: Path, drawn: list[Any], chosen: str | None, bars: int
) -> None:
    """The door plot drew FreMEn and the static mean only, while aion forecasts with the family
    it chose (the daily shape, MAE 0.13 against FreMEn's 0.17): a third bar per week names it,
    unless the choice is one of the two already drawn."""
    weeks = [{"week": k, "mae_fremen": 0.17, "mae_static": 0.19, "mae_chosen": 0.13}
             for k in range(1, 4)]
    plots.door_weeks(weeks, tmp_path / "d.png", chosen)
    (ax,) = drawn[-1].axes
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert len(labels) == bars
    assert len(ax.patches) == 3 * bars
    if bars == 3:
        assert labels[2] == f"aion's choice ({chosen})"
        heights = sorted({round(p.get_height(), 6) for p in ax.patches})
        assert heights == [0.13, 0.17, 0.19]


def test_the_direction_maps_name_their_axes_and_colours(
    tmp_path: Path, drawn: list[Any]
) -> None:
    """The grid-against-aion direction maps (the paper's Fig. 4) had no axis labels and
    coloured their arrows by flow with no colour bar saying so."""
    xy = np.array([[0.5, 0.5], [1.5, 0.5], [2.5, 0.5]])
    angle = np.zeros(3)
    flow = np.array([1.0, 2.0, 4.0])
    plots.flow_maps_side_by_side(xy, angle, flow, xy, angle, flow, tmp_path / "f.png", "t")
    fig = drawn[-1]
    maps = [ax for ax in fig.axes if ax.get_title()]
    assert len(maps) == 2
    for ax in maps:
        assert ax.get_xlabel() == "x (m)"
        assert ax.get_aspect() == 1.0
    assert maps[0].get_ylabel() == "y (m)"
    bars = [ax for ax in fig.axes if ax not in maps]
    assert len(bars) == 1
    assert "flow" in bars[0].get_ylabel()
    # the arrows are shares of the busiest flow (4), 1 m long at it, as the bar says: its
    # label read "(colour and arrow length, m)", a flow in metres
    assert "arrow length: 1 m = 1" in bars[0].get_ylabel()
    for ax in maps:
        (quiver,) = [c for c in ax.collections if type(c).__name__ == "Quiver"]
        assert np.hypot(quiver.U, quiver.V).tolist() == pytest.approx([0.25, 0.5, 1.0])
