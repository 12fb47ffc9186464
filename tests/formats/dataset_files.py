"""Track files of the public pedestrian datasets for the dataset tests: where the real ones are
(``../shared/data/tracks``) and synthetic Edinburgh and THÖR-MAGNI files whose answers follow
from how they were written."""

from __future__ import annotations

from pathlib import Path

from tests.shared_data import SHARED_DATA

TRACKS = SHARED_DATA / "tracks"
#: one real day of the Edinburgh Informatics Forum tracks
EDINBURGH = TRACKS / "edinburgh" / "tracks.01Jul.txt"
#: the folder of the real ETH/UCY 4-column files
ETH_UCY = TRACKS / "eth_ucy"
MAGNI_HEADER = "Time,frame_id,x,y,z,ag_id,data_label,map_name,best_marker_id"


def edinburgh_file(
    path: Path, tracks: dict[int, list[tuple[int, int, int]]], **props: int
) -> Path:
    """An Edinburgh tracks file at ``path``: ``tracks`` maps a track number to its ``(x, y,
    frame)`` points (pixels); ``R<n>=count`` in ``props`` overrides the point count its
    ``Properties`` line states."""
    lines = [f"% Total number of trajectories in file are  {len(tracks)} ", ""]
    for rid, points in tracks.items():
        n = props.get(f"R{rid}", len(points))
        lines.append(f"Properties.R{rid}=[{n} {points[0][2]} {points[-1][2]} 1.5 2.0 3.0 ];")
        body = ";".join(f"[{x} {y} {f}]" for x, y, f in points)
        lines.append(f" TRACK.R{rid}=[{body}];")
    path.write_text("\n".join(lines) + "\n")
    return path


def _magni_rows(n: int = 50) -> list[str]:
    """100 Hz: Helmet_3 walks +x at 1.2 m/s from (1 m, 2 m), Helmet_11 walks +y at 0.8 m/s from
    (5 m, -3 m) and is untracked on every 10th frame, the robot stands at the origin. Values
    in millimetres, as in the dataset's files."""
    rows = []
    for k in range(n):
        t = k / 100
        rows.append(
            f"{t:.2f},{k + 1},{1000 + 12 * k:.1f},2000.0,1700.2,Helmet_3,"
            f'"Visitors-Group 2",1205_SC1A_map.png,1'
        )
        if k % 10 == 9:
            rows.append(f'{t:.2f},{k + 1},,,,Helmet_11,"Carrier, Large Object",1205_SC1A_map.png,')
        else:
            rows.append(
                f"{t:.2f},{k + 1},5000.0,{-3000 + 8 * k:.1f},1650.0,Helmet_11,"
                f'"Carrier, Large Object",1205_SC1A_map.png,2'
            )
        rows.append(f"{t:.2f},{k + 1},0.0,0.0,400.0,DARKO_Robot,Robot,1205_SC1A_map.png,1")
    return rows


def magni_file(path: Path, header: str = MAGNI_HEADER, rows: list[str] | None = None) -> Path:
    """A THÖR-MAGNI CSV at ``path``: ``header``, then ``rows`` (the rows of :func:`_magni_rows`
    when None)."""
    path.write_text("\n".join([header, *(_magni_rows() if rows is None else rows)]) + "\n")
    return path
