"""Topics of one message type share one parse of the log's definition and one typestore
(:meth:`formats.logs.LogSet.typestore`): a log of thousands of camera topics parsed the same
text once per topic (~40 ms each, in ``aion info`` and ``aion build``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from aion_cli.formats.logs import open_logs
from tests.test_frame_check_sample import STRING, _write


def test_one_parse_per_definition(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Fifty topics of one type: one parse of its definition, one store for all."""
    import rosbags.typesys as typesys

    _write(tmp_path / "a.mcap", "mcap", 0, 50, 2000)
    from aion_cli.formats import typestores

    typestores._parsed.cache_clear()
    calls = []
    real = typesys.get_types_from_msg
    monkeypatch.setattr(typesys, "get_types_from_msg", lambda *a: calls.append(a) or real(*a))
    with open_logs([tmp_path / "a.mcap"]) as logs:
        names = [t.topic for t in logs.topics]
        assert len(names) > 30
        stores = {id(logs.typestore(t, STRING, "cdr")) for t in names}
        msg = next(iter(logs.messages([names[0]])))
        assert logs.decode(msg).data.startswith("0:")
    assert len(calls) == 1
    assert len(stores) == 1
