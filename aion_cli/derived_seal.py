"""The seal that binds a map's derived members to the members they were derived from.

An ordinary map stores data it could compute again from its other members, so that queries
need not: the FreMEn components (``forecast_*``, :mod:`aion_cli.engine.temporal.components`),
the pooling's prior strengths (``forecast_priors``, :mod:`~aion_cli.engine.temporal.pool_priors`)
and the pending day's provisional scores (``provisional_*``,
:mod:`~aion_cli.engine.temporal.provisional`). Each passes its checksums and its own checks
whatever the accumulators beside it hold, so a map whose accumulators (or the derived members
themselves) were rewritten by a tool that updated the checksums, or written by an aion whose
query view differed (before stop 70's fix, ``forecast_priors`` of maps written on 2026-12-07
were estimated over a view that counted the pending day and the open window as two days),
forecast with numbers that are not the map's own.

So every map aion writes carries a seal in its manifest (:data:`FIELD`, written by
:func:`seal` once every member's checksum is known: no byte is hashed twice):

* ``rules``: :data:`RULES`, the version of how derived members are computed (raised when a
  change makes them differ for the same accumulators);
* ``digest``: sha256 of the state metadata (``state``: config, open window, pending day ...)
  and of every member's name and sha256 but the Fourier sums';
* ``fourier``: sha256 of the Fourier sums' names and sha256 (apart, so that a query-only map,
  which leaves them out, still checks everything else).

A reader (:func:`derived_use`) recomputes both from the manifest it has read (microseconds:
the members' checksums are the manifest's, checked against the bytes of each member a query
reads). A mismatch, another ``rules``, or a seal that is not one means the derived members are
not the map's: the map is read as one without them, every derived number computed again from
its accumulators, exactly as a map in memory computes them (the Fourier sums read). A
query-only map cannot (it has no Fourier sums): it is refused. A map written before the seal
(before 2026-12-08, stop 71) is read as before, except that its ``forecast_priors`` are not used
when it was written before the fix of the view (:data:`VIEW_FIXED`): its queries estimate them.
(Unsealed maps written before stop 71's κ_G on observed hours only, 6720f7f7, keep their κ_G:
a changed estimator, not a wrong view, and dropping the priors of every unsealed map would
cost each of its queries the three searches the member spares.)

The seal is no signature: a tool that knows it can forge one. It catches the edits and the
old writers that do not.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aion_cli.query_only import LEFT_OUT

FIELD = "derived"
RULES = 1
"""The rules derived members are computed by: raise it when a change makes them differ for
the same accumulators (a query view defined anew), so maps written before are computed again."""
VIEW_FIXED = "2026-12-07T22:24:28Z"
"""When a query's pending day and open window became one day of the view (stop 70, e81f24e2):
``forecast_priors`` of unsealed maps written before then are not used."""
PRIORS = "forecast_priors"


@dataclass(frozen=True)
class DerivedUse:
    """Which stored derived members a reader may use: the FreMEn components and provisional
    scores (``forecasts``), the pooling's priors (``priors``)."""

    forecasts: bool = True
    priors: bool = True


def _digest(meta: Any, members: Mapping[str, Any], names: list[str]) -> str:
    """sha256 of ``meta`` and the names and sha256 of ``names`` (sorted), as canonical JSON."""
    pairs = [[name, members[name].get("sha256")] for name in sorted(names)]
    text = json.dumps({"state": meta, "members": pairs}, sort_keys=True,
                      separators=(",", ":"), allow_nan=False)  # fmt: skip
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _digests(manifest: Mapping[str, Any], members: Mapping[str, Any]) -> tuple[str, str]:
    """The ``digest`` and ``fourier`` of a map whose manifest and members table are these."""
    rest = [n for n in members if n not in LEFT_OUT]
    return (_digest(manifest.get("state"), members, rest),
            _digest(None, members, [n for n in members if n in LEFT_OUT]))  # fmt: skip


def seal(manifest: Mapping[str, Any], members: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """The seal of a map about to be written (``write_map(..., seal=seal)``)."""
    digest, fourier = _digests(manifest, members)
    return {FIELD: {"rules": RULES, "digest": digest, "fourier": fourier}}


def stale_because(manifest: Mapping[str, Any]) -> str | None:
    """Why the sealed map's derived members are not its own (None: they are, or the map has
    no seal)."""
    record = manifest.get(FIELD)
    if record is None:
        return None
    members = manifest.get("members")
    if not (isinstance(record, dict) and isinstance(members, dict)
            and all(isinstance(record.get(k), str) for k in ("digest", "fourier"))):  # fmt: skip
        return f"its {FIELD!r} seal is not a record of rules and digests"
    if record.get("rules") != RULES:
        return f"they were computed by other rules ({record.get('rules')!r}, this aion's {RULES})"
    try:
        digest, fourier = _digests(manifest, members)
    except (TypeError, ValueError):  # a state that is not JSON as written (NaN)
        return "its state cannot be digested"
    if digest != record["digest"]:
        return "its members or state are not those they were computed from"
    if any(n in members for n in LEFT_OUT) and fourier != record["fourier"]:
        return "its Fourier sums are not those they were computed from"
    return None


def derived_use(path: Path, manifest: Mapping[str, Any], query_only: bool) -> DerivedUse:
    """Which derived members of the map at ``path`` a reader may use (see the module);
    :class:`~aion_cli.errors.MapCorruptError` for a query-only map whose derived members are
    stale (without its Fourier sums they cannot be computed again)."""
    if manifest.get(FIELD) is None:  # written before the seal
        created = manifest.get("created")
        old_view = isinstance(created, str) and created < VIEW_FIXED
        return DerivedUse(priors=not (old_view and PRIORS in manifest.get("members", {})))
    why = stale_because(manifest)
    if why is None:
        return DerivedUse()
    if query_only:
        from aion_cli.errors import MapCorruptError
        from aion_cli.query_only import made_from, query_only_of

        record = query_only_of(dict(manifest))
        name = made_from(record) if record is not None else None
        raise MapCorruptError(
            f"map {path} is invalid: its stored forecasts (forecast_*, provisional_*) are not "
            f"its own ({why}), and a query-only map has no Fourier sums to compute them again",
            hint=f"make it again with aion compact from the full map{f' ({name})' if name else ''}",
        )
    return DerivedUse(forecasts=False, priors=False)
