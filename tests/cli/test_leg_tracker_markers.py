"""The RViz MarkerArray of the real leg_tracker bags: its markers are numbered 0, 1, ... in
every message (leg_tracker's ``extract_positive_training_clusters`` sets ``m.id = i``), so an
id is a place in the message, not a person. Read as track ids, id 0 jumped from one leg to
another between messages and gave 317 "track" headings of positive_1 that differenced two
people; read as numbers, the markers are linked into tracks like the PoseArray's poses they
were drawn from (same x, y: one SPHERE per pose, in frame ``laser_frame``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.cli.conftest import map_cells, run_json
from tests.shared_data import real

MARKERS = "/visualization_marker_array"


def _cells(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A map's cells (centres, counts per direction bin, undirected), in centre order."""
    xy, counts, nodir = map_cells(path)
    order = np.lexsort(xy.T)
    return xy[order], counts[order], nodir[order]


@pytest.mark.parametrize("name", ["positive_1_extracted.bag", "positive_2_extracted.bag"])
def test_numbered_markers_make_the_map_of_the_poses_they_draw(name: str, tmp_path: Path) -> None:
    log = real("logs", "leg_tracker", name)
    poses = run_json("build", log, "-o", tmp_path / "poses.aion", "--map-frame", "right_laser",
                     "--workers", "1", "--format", "json")  # fmt: skip
    markers = run_json("build", log, "-o", tmp_path / "markers.aion", "--map-frame",
                       "laser_frame", "--detections-topic", MARKERS, "--workers", "1",
                       "--format", "json")  # fmt: skip
    assert markers["detection_topics"] == [MARKERS]
    assert markers["detections"]["used"] == poses["detections"]["used"]
    assert markers["headings"]["track"] == 0
    assert markers["headings"] == poses["headings"]
    for a, b in zip(_cells(tmp_path / "markers.aion"), _cells(tmp_path / "poses.aion"),
                    strict=True):  # fmt: skip
        np.testing.assert_array_equal(a, b)
