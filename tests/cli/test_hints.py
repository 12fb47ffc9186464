"""Every error the CLI prints for a user's mistake comes with a ``hint:`` saying what to type
instead (README: "one line ``error: ...`` plus a hint"); these had none."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import SAMPLE, Office, assert_one_line_error, run


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["predict", "{map}", "--node", "p1", "--at", "1,2"], "choose --node or --at"),
        (["plan", "{map}", "--from", "p1", "--to", "p3", "--speed", "nan"], "speed must be"),
        (["plan", "{map}", "--from", "p1", "--to", "p3", "--time", "now", "--leave",
          "08:00..09:00"], "choose one of --time or --leave"),
        (["predict", "{map}", "--time", "now", "--from", "08:00", "--to", "09:00"],
         "choose one of --time or --from/--to"),
        (["export", "{map}", "--time", "now", "--path-from", "p0", "--path-to", "p4", "-o",
          "{tmp}/g.json"], "--format dsg holds no path"),
        (["export", "{map}", "--from", "08:00", "-o", "{tmp}/series"], "needs both --from and"),
        (["plan", "{tmp}", "--from", "p0", "--to", "p4"], "is a folder, not a map file"),
        (["report", "{tmp}", "-o", "{tmp}/report"], "is a folder, not a map file"),
        (["export", "{map}", "--path-from", "p1", "-o", "{tmp}/x.png"], "needs both --path-from"),
        (["export", "{map}", "--historical", "--time", "now", "-o", "{tmp}/x.png"],
         "choose one of --time, --historical"),
        (["simulate", "-o", "{tmp}/s.mcap", "--days", "0"], "--days must be positive"),
        (["simulate", "-o", "{tmp}/s.mcap", "--days", "nan"], "must be finite"),
        (["--max-chunk-mb", "0", "info", str(SAMPLE)], "the chunk limit must be"),
        (["build", str(SAMPLE), "--config", "{tmp}/bins.toml", "-o", "{tmp}/b.aion"],
         "bins must be an integer"),
        # a parameter out of its range had no hint but bins and cell_size
        (["build", str(SAMPLE), "--config", "{tmp}/order.toml", "-o", "{tmp}/b.aion"],
         "max_order must be an integer in 0..16, got 20"),
        (["evaluate", "office", "--config", "{tmp}/families.toml", "--scenes", "1"],
         "families must be a list of names"),
    ],
)
def test_an_error_comes_with_a_hint(
    office: Office, tmp_path: Path, args: list[str], fragment: str
) -> None:
    (tmp_path / "bins.toml").write_text("bins = 1\n")
    (tmp_path / "order.toml").write_text("[model]\nmax_order = 20\n")
    (tmp_path / "families.toml").write_text('families = "static"\n')
    filled = [a.format(map=office.map, tmp=tmp_path) for a in args]
    result = run(*filled)
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, fragment)
    assert any(line.startswith("hint: ") for line in result.stderr.splitlines()), result.stderr
    assert "limit=" not in result.stderr  # the read limits' hint read "e.g. the chunk limit=2048"


def test_info_of_a_mix_of_kinds_says_which_is_which(office: Office, tmp_path: Path) -> None:
    """``aion info MAP LOG`` said 'error: give either logs or maps, not both' and no hint (a
    scene-graph file beside a log likewise): the hint now says which path is of which kind and
    gives one ``aion info`` per kind."""
    import shlex

    from tests.cli.logdata import save_graph_file

    result = run("info", office.map, office.log)
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, "give either logs or maps, not both")
    said = " ".join(result.stderr.split())
    assert (f"hint: {office.map} is a map, {office.log} is a log: describe each kind apart "
            f"(aion info {shlex.quote(str(office.map))}; aion info "
            f"{shlex.quote(str(office.log))})") in said, said
    graph = save_graph_file(tmp_path / "dsg.json")
    result = run("info", graph, office.map)
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, "not a mix")
    said = " ".join(result.stderr.split())
    assert f"hint: {graph} is a scene-graph file, {office.map} is not" in said, said
