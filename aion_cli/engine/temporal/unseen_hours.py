"""The hours of the day an entry never observed, where the family it chose says nothing.

An entry chooses its flow family on the day-ahead scores of the windows it was observed in
(``scoring``). ``static`` (one constant rate) and FreMEn (sinusoids fitted to the hours
observed) were scored there only and carry nothing of an hour the entry never saw: a place
the robot passes by day only, chosen ``static`` or ``fremen1`` on its daytime counts, says
nothing of the night the robot spent elsewhere. ``shape`` and ``profile`` read the group's
periodic shape, which the entries observed at that hour measured (``profile`` at a bin
without windows *is* its ``shape`` parent: ``shrunk_rate`` with W = S = 0), so they need no
such rule. :class:`~aion_cli.engine.temporal.model.Predictor` forecasts the first two with
``shape`` at the hours :func:`unseen_own_hours` finds (:func:`blind_families`), and a map
total reconciled to FreMEn takes every entry's periodic forecast there.
"""

from __future__ import annotations

import numpy as np

from aion_cli.engine.temporal.forecast import Forecaster
from aion_cli.engine.temporal.fremen_parts import BLOCK
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pooling import rows_of
from aion_cli.engine.types import I64, BoolA


def blind_families(params: TemporalParams) -> BoolA:
    """bool[flow families]: the families that say nothing of an hour the entry never
    observed (``static`` and FreMEn) — all False without the ``shape`` family, which
    forecasts there in their stead (``ModelConfig.families``)."""
    if "shape" not in params.flow or not params.flow_enabled[params.flow.index("shape")]:
        return np.zeros(len(params.flow), dtype=bool)
    return np.array([name not in ("shape", "profile") for name in params.flow])


def unseen_own_hours(params: TemporalParams, fc: Forecaster, e: I64, map_hours: BoolA) -> BoolA:
    """bool[E, hours of the day]: for entry positions ``e``, the hours ``map_hours`` (the
    map observed on some day) at which the entry was observed on none: no window of its own
    in any kind of day, and none of a fixed sensor, which watches every entry; all False for
    the other entries."""
    per_day = params.calendar.bins_per_day
    out = np.zeros((fc.rows.size, per_day), dtype=bool)
    state = fc.state
    fixed = (state.glob.profile[0].reshape(-1, per_day) > 0).any(axis=0)
    hours = np.flatnonzero(map_hours & ~fixed)
    if e.size == 0 or hours.size == 0:
        return out
    kinds = params.n_profile // per_day
    for a in range(0, e.size, BLOCK):  # E x bins temporaries stay small on any map
        block = e[a : a + BLOCK]
        windows = np.asarray(rows_of(state.obs.profile, fc.rows[block]))  # kind-major bins
        own = windows.reshape(block.size, kinds, per_day).sum(axis=1)[:, hours] > 0
        out[block[:, None], hours[None, :]] = ~own
    return out
