"""The calendar a week-profile map forecasts with: the week's bins, or its weekdays' and
weekends' pooled, as the map's own evidence says.

A map of ``profile = "week"`` keeps its entries' sums per hour of the week (168 bins an hour
a bin). Whether its data asks for them is what the map's week sums judge day ahead
(:func:`~aion_cli.engine.temporal.week_evidence.calendar_choice`: ``week`` only when every
day of the week the map observed was observed on two days or more and the week's bins
forecast the next day better by ``family_margin`` nats). Where they say ``day_weekend``
(Lincoln's four days: one Friday standing for all Fridays), the forecast reads the same sums
pooled into hours of weekdays and of weekends (:func:`pooled_view`): every profile-binned
sum of a weekday bin summed over Monday–Friday at its hour, of a weekend bin over
Saturday–Sunday — exactly the sums a ``day_weekend`` map of the same days holds (the counts
are whole numbers; the windows and ``day_level`` add in another order, to the last bits) —
with parameters of that profile, so the pooled map forecasts, scores and chooses its
families as the ``day_weekend`` map does. Where they say ``week``, the week's bins are read
as they are, each level's week shrunk toward its own weekdays and weekends
(:func:`~aion_cli.engine.temporal.shape_prior.group_shapes`).

The choice is the map's, from sums over days (``week_sums``), so a continued build and a merge
make it as one build does; the day-ahead scoring of each day uses the calendar the map's
evidence gave *before* that day (its scores are those of the forecast a query would have
made then). A map of another profile is read as it is (``day_weekend``, the default, has no
week's bins per entry to choose: its week sums are reported, :mod:`.week_evidence`).
"""

from __future__ import annotations

import dataclasses
from functools import lru_cache

import numpy as np

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.observation_block import ObsBlock
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.shape_prior import pool_week
from aion_cli.engine.temporal.week_evidence import calendar_choice
from aion_cli.engine.types import F64


def forecast_calendar(params: TemporalParams, state: TemporalState) -> str:
    """The profile the forecast reads: the configured one, but ``day_weekend`` for a
    ``week`` map whose evidence does not ask for the week (module docstring)."""
    profile = params.calendar.profile
    if profile != "week":
        return profile
    choice = calendar_choice(state.week_sums, params.config.family_margin)
    return "week" if choice["calendar"] == "week" else "day_weekend"


def pooled_view(
    params: TemporalParams, state: TemporalState
) -> tuple[TemporalParams, TemporalState]:
    """``(params, state)`` as the forecast reads them (module docstring): the same objects
    unless a ``week`` map forecasts with ``day_weekend``; then parameters of that profile and
    a view of ``state`` whose profile-binned sums (``cnt_profile``, the observation blocks'
    ``profile``, ``day_level``) are pooled, every other array shared (scores written through
    the view land in ``state``)."""
    if forecast_calendar(params, state) == params.calendar.profile:
        return params, state
    per_day = params.calendar.bins_per_day
    view = dataclasses.replace(
        state,
        glob=_pooled_block(state.glob, per_day),
        obs=_pooled_block(state.obs, per_day),
        cnt_profile=pool_week(state.cnt_profile, per_day),
        day_level=_pooled_level(state.day_level, per_day),
    )
    return _day_weekend(params.config), view


@lru_cache(maxsize=8)
def _day_weekend(config: ModelConfig) -> TemporalParams:
    return TemporalParams(dataclasses.replace(config, profile="day_weekend"))


def _pooled_block(block: ObsBlock, bins_per_day: int) -> ObsBlock:
    pooled: F64 = pool_week(block.profile, bins_per_day)
    return dataclasses.replace(block, profile=pooled)


def _pooled_level(level: F64, bins_per_day: int) -> F64:
    """``day_level`` (float64[4, 2H]: robot slots' profile bins, then fixed-sensor slots')
    pooled per kind of slot; a map's empty sums stay empty."""
    if level.size == 0:
        return level
    robot, fixed = np.split(level, 2, axis=1)
    out: F64 = np.concatenate(
        [pool_week(robot, bins_per_day), pool_week(fixed, bins_per_day)], axis=1
    )
    return out
