"""One linker for id-less detections: ``aion convert``'s :func:`link_tracks` and the build's
:class:`TrackLinker` (fed in chunks, as ``aion_cli.detection_feed`` feeds it) give the same
tracks on the same rows, and those tracks are the people who walked."""

from __future__ import annotations

from itertools import pairwise

import numpy as np

from aion_cli.engine.tracking import LinkerConfig, TrackLinker, link_tracks

_S = 1_000_000_000


def _chunked(t: np.ndarray, xy: np.ndarray, cuts: list[int]) -> np.ndarray:
    """The build's way: one linker, fed the time-sorted rows chunk by chunk."""
    linker = TrackLinker(LinkerConfig())
    bounds = [0, *cuts, len(t)]
    return np.concatenate([linker.link(t[a:b], xy[a:b]) for a, b in pairwise(bounds)])


def _same_partition(a: np.ndarray, b: np.ndarray) -> bool:
    pairs = np.unique(np.c_[a, b], axis=0)
    return len(pairs) == len(np.unique(a)) == len(np.unique(b))


def _walkers() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Four people at 10 Hz, straight lines at constant speed: two cross at right angles in
    the middle, one walks the other way along the corridor, one is unseen for 3 frames.
    Rows in time order: stamps, positions, true person, true heading."""
    people = [  # start (m), heading (rad), speed (m/s), frames unseen
        ((-6.0, 0.0), 0.0, 1.2, ()),
        ((0.0, -6.0), np.pi / 2, 1.2, ()),
        ((6.0, 4.0), np.pi, 1.0, ()),
        ((-5.0, -4.0), 0.3, 1.4, (40, 41, 42)),
    ]
    rows = []
    for k, ((x0, y0), h, v, unseen) in enumerate(people):
        for f in range(100):
            if f in unseen:
                continue
            d = v * f * 0.1
            rows.append((f * _S // 10, x0 + d * np.cos(h), y0 + d * np.sin(h), k, h))
    a = np.array(sorted(rows, key=lambda r: (r[0], r[3])))
    return a[:, 0].astype(np.int64), a[:, 1:3], a[:, 3].astype(np.int64), a[:, 4]


def test_walkers_are_linked_into_their_true_tracks_on_both_paths() -> None:
    t, xy, person, truth = _walkers()
    links = link_tracks(t, xy)
    assert links.n_tracks == 4  # no fragments through the crossing or the 0.4 s gap
    assert _same_partition(links.track_id, person)
    # every row walks 0.1 m or more per frame: each one has a heading, the true one
    assert not np.isnan(links.heading).any()
    err = np.angle(np.exp(1j * (links.heading - truth)))
    assert np.abs(err).max() < 1e-6
    for every in (4, 37, 101):  # chunks end between frames, as messages do
        cuts = [c for c in range(every, len(t), every) if t[c] != t[c - 1]]
        assert np.array_equal(_chunked(t, xy, cuts), links.track_id)


# Lincoln 2017-06-09, 1497004399 .. 1497004404 (whole-second stamps; rows in file order):
# two detections of one passer-by per frame make an exact tie between two assignments.
_LINCOLN_T = [-1, -1, 0, 0, 1, 1, 1, 1, 1, 1, 2, 2, 2, 2, 2, 2, 3, 3, 3, 3, 3, 3, 3, 4, 4]
_LINCOLN_XY = [
    (2.9960807637, -1.22540998812),
    (2.4037154244599996, -1.1813491216399998),
    (1.9949654237999999, -1.3053340654999999),
    (1.96810900893, -1.36479097961),
    (1.9930346965299999, -1.46460287106),
    (1.3051847106399999, -1.28355896949),
    (0.6707649765079999, -1.03893419073),
    (1.9182757657799998, -1.54207418558),
    (1.0400425980299999, -1.3936192837799999),
    (0.5994287259960001, -1.12498588869),
    (1.84351665679, -1.61954568481),
    (0.31164856093000004, -1.7661028497799998),
    (0.43066273315399994, -1.1399292561799999),
    (1.7637734551099997, -1.7021821082700002),
    (-0.26911644162500004, -2.06770945867),
    (0.09999717938989999, -1.1459906595799998),
    (1.6840310020299998, -1.7848177559599998),
    (-0.849875992149, -2.36931323619),
    (-0.160375477436, -1.1627478959100002),
    (-1.03842579828, -1.0712708748200002),
    (-1.4669260859600002, -2.68976365158),
    (-0.437018318994, -1.18055225958),
    (-1.70527031558, -1.09016601435),
    (-0.697398308769, -1.1973099678499999),
    (-2.24283609002, -1.1231086747799999),
]


def test_a_tie_is_broken_alike_by_convert_and_the_build() -> None:
    """Before, link_tracks had an association loop of its own (``_associate``): on these rows
    it swapped two tracks against the build's linker (on the whole file, 2 of 2,856 tracks)."""
    t = (1497004400 + np.array(_LINCOLN_T, np.int64)) * _S
    xy = np.array(_LINCOLN_XY)
    convert = link_tracks(t, xy).track_id
    assert np.array_equal(convert, _chunked(t, xy, [10, 16]))
    assert np.array_equal(convert, TrackLinker().link(t, xy))


def test_a_frame_cut_between_two_calls_gives_each_track_one_detection_of_it() -> None:
    """A build decodes messages in jobs of a few thousand; a job may end between two messages
    of one stamp. Before, the second message's rows were gated against tracks that already
    had their detection of that stamp (gate 0.3 m, dt = 0), so a second detection of the
    walker (the Lincoln detector's duplicates) joined its track: two positions at one time."""
    t = np.array([0, 1, 2, 3, 3, 4, 5], np.int64) * _S
    xy = np.array([(0, 0), (1, 0), (2, 0), (3, 0), (3.1, 0.05), (4, 0), (5, 0)], float)
    whole = link_tracks(t, xy).track_id
    assert whole.tolist() == [0, 0, 0, 0, 1, 0, 0]  # the duplicate is a track of its own
    split = _chunked(t, xy, [4])  # the stamp-3 frame is two messages, in two jobs
    assert np.array_equal(split, whole)
    for k in np.unique(split):
        assert len(np.unique(t[split == k])) == np.count_nonzero(split == k)
