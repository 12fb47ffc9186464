"""``aion report``: one self-contained HTML page about a map, with the pictures it shows.

* :mod:`aion_cli.report.content` — what the page says, gathered from the map with the
  library's own queries (the manifest as ``aion info`` shows it, ``predicted_records`` as
  ``aion predict`` gives them, ``flow_series`` for many times at once);
* :mod:`aion_cli.report.plots` — the PNG pictures (matplotlib ``Figure`` objects on the Agg
  canvas, no pyplot state);
* :mod:`aion_cli.report.page` — the HTML (inline CSS, no script, every map string escaped);
* :mod:`aion_cli.report.writer` — :func:`~aion_cli.report.writer.write_report`, which writes
  them into a staging folder and moves them in when complete.

No click or rich here: the command is ``aion_cli.cli.report``.
"""
