"""Pictures of a map with matplotlib (Agg, no pyplot state): the top-down flow map
(:mod:`.topdown`, drawn over :mod:`.backdrop`: mesh footprint and room outlines), the plan
picture (:mod:`.plan`) and writing them as PNG files of a map (:mod:`.render`, behind
``aion export --format png`` and ``aion plan --png``). No click or rich here; the drawing
functions take plain arrays (:class:`aion_cli.scene.Scene`)."""
