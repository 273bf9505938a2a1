"""Markers: corresponding feet points dropped by linked targets (SPEC §5, thesis §3.2.5).

Every ``marker_every_frames`` frames, each linked pair (a_label, b_label) present in both cameras
drops a marker (x_a, x_b) only if (a) both targets are fully inside their frames, (b) both heights
are within ``height_tolerance`` of their median over the last ``height_window_frames`` frames, and
(c) one of the two feet moved more than ``marker_min_move_px`` since that link's last marker.
The store keeps one marker per cell of a grid over A's frame (newest wins), so it stays bounded
and keeps spatial coverage.

    state = markers_init(size_a)
    state, result = marker_step(state, [(3, 7)], targets_a, targets_b, cfg, frame_index)
    pts_a, pts_b = marker_points(state)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from mvtrack.params import MarkerConfig
from mvtrack.stages.homography import (
    solve_homographies,
    solve_homography,
    transfer_errors,
    transfer_errors_many,
)
from mvtrack.stages.targets import SIDES, CameraTargets

__all__ = [
    "Candidates",
    "Comotion",
    "Marker",
    "MarkerResult",
    "MarkerState",
    "candidates_add",
    "comotion_confirm",
    "comotion_draws",
    "comotion_of_run",
    "comotion_search",
    "marker_groups",
    "marker_points",
    "marker_step",
    "markers_add",
    "markers_init",
    "not_shrunk",
    "poolable",
]


@dataclass(frozen=True)
class Marker:
    """One corresponding feet pair: x_a in camera A's pixels, x_b in camera B's."""

    frame: int
    a_label: int
    b_label: int
    x_a: tuple[float, float]
    x_b: tuple[float, float]
    h_a: float = 0.0
    h_b: float = 0.0
    """The two targets' heights in px (0: unknown)."""


@dataclass(frozen=True)
class MarkerState:
    """Marker store and the histories the three tests need. Never mutated: steps copy.

    size_a:     (width, height) of camera A (the store's grid covers it)
    cells:      grid cell index -> newest marker in that cell
    last:       (a_label, b_label) -> that link's last marker (test c)
    heights_a:  label -> heights over the last ``height_window_frames`` frames, camera A
    heights_b:  the same for camera B
    n_dropped:  markers ever dropped (the store holds at most grid_cols * grid_rows)
    """

    size_a: tuple[int, int]
    cells: dict[int, Marker]
    last: dict[tuple[int, int], Marker]
    heights_a: dict[int, tuple[float, ...]]
    heights_b: dict[int, tuple[float, ...]]
    n_dropped: int = 0


@dataclass(frozen=True)
class MarkerResult:
    """What marker dropping did this frame.

    tried:     whether this was a marker frame
    dropped:   markers dropped this frame
    rejected:  (a_label, b_label, reason) for each link that failed a test this frame;
               reason is "outside", "height" or "no motion"
    markers:   every marker in the store after this frame, oldest first
    """

    tried: bool
    dropped: tuple[Marker, ...]
    rejected: tuple[tuple[int, int, str], ...]
    markers: tuple[Marker, ...]


def markers_init(size_a: tuple[int, int]) -> MarkerState:
    return MarkerState(size_a, {}, {}, {}, {})


def marker_points(state: MarkerState) -> tuple[np.ndarray, np.ndarray]:
    """((N, 2), (N, 2)) float64 copies of the stored markers' x_a and x_b, oldest first."""
    markers = sorted(state.cells.values(), key=lambda m: m.frame)
    if not markers:
        return np.zeros((0, 2)), np.zeros((0, 2))
    return np.array([m.x_a for m in markers]), np.array([m.x_b for m in markers])


def marker_groups(state: MarkerState) -> np.ndarray:
    """(N,) int64: per stored marker (:func:`marker_points` order), an id of its link."""
    markers = sorted(state.cells.values(), key=lambda m: m.frame)
    ids: dict[tuple[int, int], int] = {}
    return np.array([ids.setdefault((m.a_label, m.b_label), len(ids)) for m in markers], np.int64)


def _update_heights(
    history: dict[int, tuple[float, ...]], targets: CameraTargets, window: int
) -> dict[int, tuple[float, ...]]:
    """Per-label height history of present targets (absent labels are forgotten)."""
    return {
        label: (*history.get(label, ()), float(h))[-window:]
        for label, h in zip(targets.labels.tolist(), targets.heights_px.tolist(), strict=True)
    }


def _height_ok(history: tuple[float, ...], cfg: MarkerConfig) -> bool:
    median = float(np.median(history))
    return abs(history[-1] - median) <= cfg.height_tolerance * median


def not_shrunk(
    history: dict[int, tuple[float, ...]], targets: CameraTargets, cfg: MarkerConfig
) -> np.ndarray:
    """(N,) bool per target: its height this frame is not below the median of its window
    (``history``, :class:`MarkerState`'s heights before this frame, and this one) by more than
    ``height_tolerance``, the lower half of test (b)."""
    now = _update_heights(history, targets, cfg.height_window_frames)
    return np.array([now[label][-1] >= (1 - cfg.height_tolerance) * float(np.median(now[label]))
                     for label in targets.labels.tolist()], bool)


def poolable(
    heights: tuple[dict[int, tuple[float, ...]], dict[int, tuple[float, ...]]],
    a: CameraTargets, b: CameraTargets, cfg: MarkerConfig,
) -> tuple[CameraTargets, CameraTargets]:
    """The targets the co-motion pool may take this frame: with ``comotion_height_test``,
    those not shrunk (:func:`not_shrunk`) against their cameras' height ``heights``. A blob
    that lost its legs has its feet off: it fits no H."""
    if not cfg.comotion_height_test:
        return a, b
    return a.subset(not_shrunk(heights[0], a, cfg)), b.subset(not_shrunk(heights[1], b, cfg))


def _cell(x_a: tuple[float, float], size_a: tuple[int, int], cfg: MarkerConfig) -> int:
    width, height = size_a
    col = int(np.clip((x_a[0] + 0.5) * cfg.grid_cols // width, 0, cfg.grid_cols - 1))
    row = int(np.clip((x_a[1] + 0.5) * cfg.grid_rows // height, 0, cfg.grid_rows - 1))
    return row * cfg.grid_cols + col


def _test_link(
    link: tuple[int, int],
    rows: tuple[int, int],
    inside: tuple[np.ndarray, np.ndarray],
    heights: tuple[dict[int, tuple[float, ...]], dict[int, tuple[float, ...]]],
    cfg: MarkerConfig,
) -> str:
    """The first test the link fails this frame ("" if it passes all three, except motion)."""
    if not (inside[0][rows[0]] and inside[1][rows[1]]):
        return "outside"
    if not (_height_ok(heights[0][link[0]], cfg) and _height_ok(heights[1][link[1]], cfg)):
        return "height"
    return ""


def marker_step(
    state: MarkerState,
    links: Sequence[tuple[int, int]],
    a: CameraTargets,
    b: CameraTargets,
    cfg: MarkerConfig,
    frame: int,
) -> tuple[MarkerState, MarkerResult]:
    """Update height histories; on marker frames drop a marker for each link passing the tests.

    ``links`` are (A label, B label) pairs (FOV associations or meta-targets); links with a
    target absent this frame are skipped. Markers of links whose targets are gone are kept.
    """
    heights = (
        _update_heights(state.heights_a, a, cfg.height_window_frames),
        _update_heights(state.heights_b, b, cfg.height_window_frames),
    )
    tried = frame % cfg.marker_every_frames == 0
    cells, last = dict(state.cells), dict(state.last)
    dropped: list[Marker] = []
    rejected: list[tuple[int, int, str]] = []
    if tried and links:
        inside = (_inside(a, cfg), _inside(b, cfg))
        for link in links:
            ra, rb = a.index_of(link[0]), b.index_of(link[1])
            if ra is None or rb is None:
                continue
            reason = _test_link(link, (ra, rb), inside, heights, cfg)
            marker = Marker(
                frame, link[0], link[1], _pt(a.feet[ra]), _pt(b.feet[rb]),
                float(a.heights_px[ra]), float(b.heights_px[rb]),
            )
            if not reason and not _moved(last.get(link), marker, cfg):
                reason = "no motion"
            if reason:
                rejected.append((link[0], link[1], reason))
                continue
            dropped.append(marker)
            last[link] = marker
            cells[_cell(marker.x_a, state.size_a, cfg)] = marker
    live = (set(a.labels.tolist()), set(b.labels.tolist()))
    last = {k: m for k, m in last.items() if k[0] in live[0] and k[1] in live[1]}
    new_state = MarkerState(
        state.size_a, cells, last, heights[0], heights[1], state.n_dropped + len(dropped)
    )
    markers = tuple(sorted(cells.values(), key=lambda m: m.frame))
    return new_state, MarkerResult(tried, tuple(dropped), tuple(rejected), markers)


def _inside(targets: CameraTargets, cfg: MarkerConfig, top_cut: bool = False) -> np.ndarray:
    """(N,) bool: test (a), the target's box is inside its frame by ``inside_margin_px``; with
    ``top_cut`` on every side but the top (a target cut only by the top border has its feet
    in view)."""
    sides = targets.touches(cfg.inside_margin_px)
    if top_cut:
        sides = np.delete(sides, SIDES.index("top"), axis=1)
    return np.asarray(~sides.any(axis=1), bool)


def _pt(xy: np.ndarray) -> tuple[float, float]:
    return float(xy[0]), float(xy[1])


def _moved(previous: Marker | None, marker: Marker, cfg: MarkerConfig) -> bool:
    """Test (c): no previous marker, or at least one of the feet moved far enough from it."""
    if previous is None:
        return True
    da = np.hypot(marker.x_a[0] - previous.x_a[0], marker.x_a[1] - previous.x_a[1])
    db = np.hypot(marker.x_b[0] - previous.x_b[0], marker.x_b[1] - previous.x_b[1])
    return bool(max(da, db) > cfg.marker_min_move_px)


@dataclass(frozen=True)
class Candidates:
    """Co-present feet pairs pooled while no homography is known (the co-motion bootstrap).

    frame (P,) int64; labels (P, 2) int64 [A label, B label]; x_a, x_b (P, 2) float64 px;
    heights (P, 2) float64 px [in A, in B].
    Every pair of targets fully inside both frames on a marker frame is a candidate; the
    true pairs among them are consistent with one homography, the others are not.
    """

    frame: np.ndarray
    labels: np.ndarray
    x_a: np.ndarray
    x_b: np.ndarray
    heights: np.ndarray

    @classmethod
    def empty(cls) -> Candidates:
        return cls(np.zeros(0, np.int64), np.zeros((0, 2), np.int64), np.zeros((0, 2)),
                   np.zeros((0, 2)), np.zeros((0, 2)))

    def gates_px(self, cfg: MarkerConfig) -> np.ndarray:
        """(P,) inlier gate of each candidate: the px floor or a fraction of its heights."""
        return np.maximum(cfg.comotion_threshold_px,
                          cfg.comotion_threshold_heights * self.heights.mean(axis=1))

    def __len__(self) -> int:
        return len(self.frame)

    def without(self, pairs: frozenset[tuple[int, int]]) -> Candidates:
        """The pool without the candidates of these (A label, B label) pairs."""
        keep = _not_in(pairs, self.labels[:, 0], self.labels[:, 1])
        if keep.all():
            return self
        return Candidates(self.frame[keep], self.labels[keep], self.x_a[keep], self.x_b[keep],
                          self.heights[keep])


@dataclass(frozen=True)
class Comotion:
    """A homography hypothesis supported by several target pairs moving together.

    H_b_from_a: (3, 3) fitted to the supported pairs' candidates;  links: supported
    (A label, B label) pairs;  markers: their inlier candidates as markers;
    since: newest pool frame it has been checked against (held-out candidates come later)
    """

    H_b_from_a: np.ndarray
    links: tuple[tuple[int, int], ...]
    markers: tuple[Marker, ...]
    since: int = -1


def _not_in(pairs: frozenset[tuple[int, int]], a_labels: np.ndarray,
            b_labels: np.ndarray) -> np.ndarray:
    """(N,) bool: (a_labels[i], b_labels[i]) is not one of ``pairs``."""
    return np.array([(x, y) not in pairs
                     for x, y in zip(a_labels.tolist(), b_labels.tolist(), strict=True)], bool)


def candidates_add(
    pool: Candidates, a: CameraTargets, b: CameraTargets, cfg: MarkerConfig, frame: int,
    exclude: frozenset[tuple[int, int]] = frozenset(),
) -> Candidates:
    """The pool with every (A, B) pair of fully-inside targets of this frame (bounded), but
    the (A label, B label) pairs in ``exclude``."""
    new = _frame_candidates(a, b, cfg, frame, exclude)
    if new is None:
        return pool
    return _joined((pool, new), keep=cfg.comotion_pool_size)


def _frame_candidates(
    a: CameraTargets, b: CameraTargets, cfg: MarkerConfig, frame: int,
    exclude: frozenset[tuple[int, int]] = frozenset(), top_cut: bool = False,
) -> Candidates | None:
    """Every (A, B) pair of fully-inside targets (:func:`_inside`) of a marker frame but those
    in ``exclude``; None on other frames or when there is none."""
    if frame % cfg.marker_every_frames or not len(a) or not len(b):
        return None
    ia = np.flatnonzero(_inside(a, cfg, top_cut))
    ib = np.flatnonzero(_inside(b, cfg, top_cut))
    ga, gb = (g.ravel() for g in np.meshgrid(ia, ib, indexing="ij"))
    if exclude:
        ok = _not_in(exclude, a.labels[ga], b.labels[gb])
        ga, gb = ga[ok], gb[ok]
    if not len(ga):
        return None
    return Candidates(np.full(len(ga), frame, np.int64), np.c_[a.labels[ga], b.labels[gb]],
                      a.feet[ga], b.feet[gb], np.c_[a.heights_px[ga], b.heights_px[gb]])


def _joined(parts: Sequence[Candidates], keep: int | None = None) -> Candidates:
    """The candidates of ``parts`` in order (only the newest ``keep`` when given)."""
    last = slice(None if keep is None else -keep, None)
    return Candidates(
        np.concatenate([p.frame for p in parts])[last],
        np.concatenate([p.labels for p in parts])[last].astype(np.int64),
        np.concatenate([p.x_a for p in parts])[last],
        np.concatenate([p.x_b for p in parts])[last],
        np.concatenate([p.heights for p in parts])[last],
    )


def _one_to_one(
    pairs: np.ndarray, n_in: np.ndarray, ok: np.ndarray
) -> list[tuple[int, int]]:
    """Supported label pairs, strongest first, skipping any that reuse a label."""
    chosen: list[tuple[int, int]] = []
    for k in np.flatnonzero(ok)[np.argsort(-n_in[ok], kind="stable")]:
        pa, pb = int(pairs[k, 0]), int(pairs[k, 1])
        if all(pa != x and pb != y for x, y in chosen):
            chosen.append((pa, pb))
    return chosen


@dataclass(frozen=True)
class _PairIndex:
    """The pool's distinct label pairs: pairs (K, 2) int64, sorted; of (P,) int64, each
    candidate's pair; n (K,) int64, candidates per pair; order (P,) int64, the candidate rows
    grouped by pair, pair k's from starts[k] (K,) int64 on (:meth:`rows`)."""

    pairs: np.ndarray
    of: np.ndarray
    n: np.ndarray
    order: np.ndarray
    starts: np.ndarray

    @classmethod
    def of_pool(cls, pool: Candidates) -> _PairIndex:
        pairs, inverse = np.unique(pool.labels, axis=0, return_inverse=True)
        inverse = inverse.ravel()
        n = np.bincount(inverse, None, len(pairs))
        return cls(pairs, inverse, n, np.argsort(inverse, kind="stable"), np.cumsum(n) - n)

    def rows(self, k: int) -> np.ndarray:
        """(n[k],) int64: the candidate rows of pair k."""
        return self.order[self.starts[k] : self.starts[k] + self.n[k]]


def comotion_draws(cfg: MarkerConfig, eligible: int) -> int:
    """RANSAC draws of one search over ``eligible`` target pairs: ``comotion_iterations``, or
    in a crowd enough that every two pairs are drawn ``comotion_draws_per_combination`` times
    on average. A right sample needs two true pairs; their share of all two-pair combinations
    falls with the square of the pairs, so a fixed count that finds them among 40 pairs almost
    never does among 130 (generated 'crowd', seeds 1 and 2: no homography in 600 frames)."""
    combinations = eligible * (eligible - 1) // 2
    return max(cfg.comotion_iterations,
               math.ceil(cfg.comotion_draws_per_combination * combinations))


def _draw_samples(index: _PairIndex, cfg: MarkerConfig, rng: np.random.Generator) -> np.ndarray:
    """(S, 4) int64 candidate rows of the iterations whose draw gave a sample, in order.

    Two candidates of each of two label pairs that share no label; drawing whole target pairs
    (not single candidates) makes a correct sample likely even when most candidates are
    wrong: it needs two true pairs, not four true candidates. All :func:`comotion_draws` draws
    are made at once, with the same ``rng`` calls whatever the pool holds (a loop of
    ``rng.choice`` calls took two thirds of a 15000-draw search).
    """
    eligible = np.flatnonzero(index.n >= max(cfg.comotion_min_support, 2))
    if len(eligible) < 2:
        return np.zeros((0, 4), np.int64)
    draws = comotion_draws(cfg, len(eligible))
    first = rng.integers(0, len(eligible), draws)
    second = rng.integers(0, len(eligible) - 1, draws)
    i, j = eligible[first], eligible[second + (second >= first)]  # two distinct pairs
    keep = (index.pairs[i, 0] != index.pairs[j, 0]) & (index.pairs[i, 1] != index.pairs[j, 1])

    def two_of(pair: np.ndarray) -> np.ndarray:  # two distinct candidate rows of each pair
        one = (rng.random(draws) * index.n[pair]).astype(np.int64)
        other = (rng.random(draws) * (index.n[pair] - 1)).astype(np.int64)
        other += other >= one
        begin = index.starts[pair]
        return np.stack([index.order[begin + one], index.order[begin + other]], axis=1)

    return np.concatenate([two_of(i), two_of(j)], axis=1)[keep]


def _pair_support(
    n_in: np.ndarray, n_all: np.ndarray, cfg: MarkerConfig, min_support: int
) -> np.ndarray:
    """(..., K) bool: label pairs with ``min_support`` inliers that are mostly inliers."""
    return (n_in >= min_support) & (n_in >= cfg.comotion_min_frac * n_all)


def _support(
    pool: Candidates, H: np.ndarray, cfg: MarkerConfig,
    errors: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray],
    rows: np.ndarray | None = None,
    min_support: int | None = None,
) -> tuple[list[tuple[int, int]], np.ndarray]:
    """(chosen one-to-one supporting label pairs, (P,) bool inlier rows of those pairs) of
    ``H`` over the pool's ``rows`` ((P,) bool, default all); a pair needs ``min_support``
    inliers (default ``cfg.comotion_min_support``) and mostly inliers."""
    min_support = cfg.comotion_min_support if min_support is None else min_support
    rows = np.ones(len(pool), bool) if rows is None else rows
    index = _PairIndex.of_pool(pool)
    inlier = (errors(H, pool.x_a, pool.x_b) < pool.gates_px(cfg)) & rows
    return _chosen_rows(index, inlier, np.bincount(index.of, rows, len(index.pairs)), cfg,
                        min_support)


def _chosen_rows(
    index: _PairIndex, inlier: np.ndarray, n_all: np.ndarray, cfg: MarkerConfig,
    min_support: int,
) -> tuple[list[tuple[int, int]], np.ndarray]:
    """:func:`_support` from the (P,) bool inlier rows and the (K,) candidates per pair."""
    n_in = np.bincount(index.of, inlier, len(index.pairs))
    ok = _pair_support(n_in, n_all, cfg, min_support)
    if ok.sum() < 1:
        return [], inlier & False
    chosen = _one_to_one(index.pairs, n_in, ok)
    keep = np.isin(index.of, [k for k in range(len(index.pairs))
                              if (int(index.pairs[k, 0]), int(index.pairs[k, 1])) in chosen])
    return chosen, inlier & keep


def _as_comotion(pool: Candidates, H: np.ndarray, chosen: list[tuple[int, int]],
                 rows: np.ndarray, since: int) -> Comotion:
    markers = tuple(
        Marker(int(f), int(la), int(lb), _pt(xa), _pt(xb), float(h[0]), float(h[1]))
        for f, (la, lb), xa, xb, h in zip(
            pool.frame[rows], pool.labels[rows], pool.x_a[rows], pool.x_b[rows],
            pool.heights[rows], strict=True,
        )
    )
    return Comotion(H, tuple(sorted(chosen)), markers, since)


def _best_each(
    pool: Candidates, index: _PairIndex, samples: np.ndarray, cfg: MarkerConfig,
    fit: Callable[[np.ndarray, np.ndarray], np.ndarray | None],
    errors: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray],
) -> np.ndarray | None:
    """(P,) bool inlier rows of the first best-supported sample, one sample at a time (any
    ``fit`` and ``errors``), or None when no sample has ``comotion_min_pairs`` pairs."""
    best: tuple[int, np.ndarray] | None = None
    for sample in samples:
        H = fit(pool.x_a[sample], pool.x_b[sample])
        if H is None:
            continue
        chosen, rows = _support(pool, H, cfg, errors)
        if len(chosen) >= cfg.comotion_min_pairs and (best is None or rows.sum() > best[0]):
            best = (int(rows.sum()), rows)
    return None if best is None else best[1]


_CHUNK = 128
"""Hypotheses whose transfer errors are computed at once in :func:`_best_batched`."""


def _best_batched(
    pool: Candidates, index: _PairIndex, samples: np.ndarray, cfg: MarkerConfig
) -> np.ndarray | None:
    """:func:`_best_each` with ``solve_homography`` and ``transfer_errors``, batched: one
    normalized DLT of all samples, the transfer errors of a chunk of hypotheses over the whole
    pool at once, per-pair inlier counts with one bincount, and the one-to-one selection only
    for hypotheses that can reach ``comotion_min_pairs`` pairs and beat the best so far. A
    hypothesis with an error within a relative 1e-9 of its gate is redone one at a time, so
    float rounding never changes the answer."""
    Hs, solved = solve_homographies(pool.x_a[samples], pool.x_b[samples])
    valid = np.flatnonzero(solved)
    gates = pool.gates_px(cfg)
    n_pairs = len(index.pairs)
    best, best_count = None, -1
    for start in range(0, len(valid), _CHUNK):
        chunk = valid[start:start + _CHUNK]
        err = transfer_errors_many(Hs[chunk], pool.x_a, pool.x_b)
        inlier = err < gates
        near = (np.abs(err - gates) <= 1e-9 * gates).any(axis=1)
        for c in np.flatnonzero(near):
            H = solve_homography(pool.x_a[samples[chunk[c]]], pool.x_b[samples[chunk[c]]])
            inlier[c] = (False if H is None else
                         transfer_errors(H, pool.x_a, pool.x_b) < gates)
        hit = np.nonzero(inlier)
        n_in = np.bincount(hit[0] * n_pairs + index.of[hit[1]], None,
                           len(chunk) * n_pairs).reshape(len(chunk), n_pairs)
        ok = _pair_support(n_in, index.n, cfg, cfg.comotion_min_support)
        bound = np.where(ok, n_in, 0).sum(axis=1)
        for c in np.flatnonzero((ok.sum(axis=1) >= cfg.comotion_min_pairs)
                                & (bound > best_count)):
            if bound[c] <= best_count:
                continue
            chosen, rows = _chosen_rows(index, inlier[c], index.n, cfg,
                                        cfg.comotion_min_support)
            if len(chosen) >= cfg.comotion_min_pairs and rows.sum() > best_count:
                best, best_count = rows, int(rows.sum())
    return best


def comotion_search(
    pool: Candidates,
    cfg: MarkerConfig,
    fit: Callable[[np.ndarray, np.ndarray], np.ndarray | None],
    errors: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray],
    rng: np.random.Generator,
) -> Comotion | None:
    """RANSAC over the pool for a homography that at least ``comotion_min_pairs`` distinct,
    one-to-one target pairs follow (each with ``comotion_min_support`` inliers, and mostly
    inliers; a candidate is an inlier within :meth:`Candidates.gates_px`). Samples are two
    candidates of each of two target pairs. ``fit(pts_a, pts_b)`` returns H or None
    (degenerate); ``errors(H, pts_a, pts_b)`` the per-point transfer error in px. None when no
    hypothesis is supported. The hypothesis's ``since`` is the pool's newest frame.

    With ``fit=solve_homography`` and ``errors=transfer_errors`` (what the pair stage passes)
    the iterations are evaluated batched (:func:`_best_batched`), with the same answer as one
    at a time for the same ``rng``; other callables are called once per sample.
    """
    if len(pool) < 4:
        return None
    index = _PairIndex.of_pool(pool)
    samples = _draw_samples(index, cfg, rng)
    if fit is solve_homography and errors is transfer_errors:
        best = _best_batched(pool, index, samples, cfg)
    else:
        best = _best_each(pool, index, samples, cfg, fit, errors)
    if best is None:
        return None
    H = fit(pool.x_a[best], pool.x_b[best])
    if H is None:
        return None
    chosen, rows = _support(pool, H, cfg, errors)
    if len(chosen) < cfg.comotion_min_pairs:
        return None
    return _as_comotion(pool, H, chosen, rows, int(pool.frame.max()))


def comotion_of_run(
    run: Iterable[tuple[int, CameraTargets, CameraTargets]], cfg: MarkerConfig, seed: int,
    top_cut: bool = False,
) -> Comotion | None:
    """:func:`comotion_search` over every candidate of a whole run [beyond]: ``run`` gives
    (frame, A targets, B targets) for every frame in order; candidates are pooled as the
    bootstrap pools them (marker frames, fully inside, or but for the top with ``top_cut``, no
    target shorter than its recent median with ``comotion_height_test``) but the pool is not
    bounded. For the whole-run labels (`pipeline.resolve_rows`): a pair can end a run without
    a homography, as the bootstrap's held-out check needs candidates after the search and a
    run can end first (generated 'three' seeds 7 and 10 found their three true pairs at
    frame 575 of 600), or with one gone wrong late."""
    parts = [Candidates.empty()]
    heights: tuple[dict[int, tuple[float, ...]], dict[int, tuple[float, ...]]] = ({}, {})
    for frame, a, b in run:
        if frame % cfg.marker_every_frames == 0:
            new = _frame_candidates(*poolable(heights, a, b, cfg), cfg, frame, top_cut=top_cut)
            parts += [] if new is None else [new]
        heights = (_update_heights(heights[0], a, cfg.height_window_frames),
                   _update_heights(heights[1], b, cfg.height_window_frames))
    rng = np.random.default_rng([seed, 2])
    return comotion_search(_joined(parts), cfg, solve_homography, transfer_errors, rng)


def comotion_confirm(
    pool: Candidates,
    hypothesis: Comotion,
    cfg: MarkerConfig,
    fit: Callable[[np.ndarray, np.ndarray], np.ndarray | None],
    errors: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray],
    frame: int,
) -> tuple[str, Comotion | None]:
    """The held-out check, at ``frame``, of a hypothesis on the pool's candidates newer than
    ``hypothesis.since`` (never used to find it). Returns (verdict, hypothesis):

    "confirmed", the hypothesis extended by the confirming pairs and their inliers, when at
    least ``comotion_confirm_pairs`` one-to-one target pairs follow it again
    (``comotion_confirm_support`` inliers each, mostly inliers); "rejected", None when one of
    its own pairs has that many new candidates but mostly beyond ``comotion_refute_gates``
    inlier gates (it stopped explaining its own evidence; a fit to a few people's early paths
    extrapolates loosely, so only a clear miss refutes); "confirmed" too when that loose fit
    missed a newcomer but refitting it with the newcomer's candidates keeps every pair of the
    hypothesis and the newcomer (:func:`_refit_confirm`: the pairing is confirmed); once
    ``comotion_confirm_frames`` passed since it was found with neither, "unrefuted" with the
    hypothesis unchanged if ``comotion_accept_unrefuted``, else "rejected"; before that,
    "waiting", the hypothesis unchanged.
    """
    if cfg.comotion_confirm_pairs == 0:
        return "confirmed", hypothesis
    new = pool.frame > hypothesis.since
    decided = _held_out(pool, hypothesis, new, cfg, fit, errors) if new.any() else None
    if decided is not None:
        return decided
    if frame - hypothesis.since > cfg.comotion_confirm_frames:
        return ("unrefuted", hypothesis) if cfg.comotion_accept_unrefuted else ("rejected", None)
    return "waiting", hypothesis


def _held_out(
    pool: Candidates, hypothesis: Comotion, new: np.ndarray, cfg: MarkerConfig,
    fit: Callable[[np.ndarray, np.ndarray], np.ndarray | None],
    errors: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray],
) -> tuple[str, Comotion | None] | None:
    """:func:`comotion_confirm`'s verdict from the ``new`` candidates: confirmed (by the
    hypothesis's H, else by a refit), rejected, or None (no decision)."""
    chosen, rows = _support(pool, hypothesis.H_b_from_a, cfg, errors, new,
                            cfg.comotion_confirm_support)
    if len(chosen) >= cfg.comotion_confirm_pairs:
        later = _as_comotion(pool, hypothesis.H_b_from_a, chosen, rows, int(pool.frame.max()))
        links = tuple(sorted(set(hypothesis.links) | set(chosen)))
        return "confirmed", Comotion(hypothesis.H_b_from_a, links,
                                     hypothesis.markers + later.markers, later.since)
    near = (errors(hypothesis.H_b_from_a, pool.x_a, pool.x_b)
            < cfg.comotion_refute_gates * pool.gates_px(cfg))
    for a_label, b_label in hypothesis.links:
        own = new & (pool.labels[:, 0] == a_label) & (pool.labels[:, 1] == b_label)
        n_own = int(own.sum())
        if n_own >= cfg.comotion_confirm_support and (
                (near & own).sum() < cfg.comotion_min_frac * n_own):
            return "rejected", None
    refit = _refit_confirm(pool, hypothesis, new, cfg, fit, errors)
    return None if refit is None else ("confirmed", refit)


def _refit_confirm(
    pool: Candidates, hypothesis: Comotion, new: np.ndarray, cfg: MarkerConfig,
    fit: Callable[[np.ndarray, np.ndarray], np.ndarray | None],
    errors: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray],
) -> Comotion | None:
    """The hypothesis refitted to its markers and the ``new`` candidates of one target pair
    that shares no label with it, when the pool's support of the refit (:func:`_support`)
    holds that pair and every pair of the hypothesis (the one with most inliers if several
    do); else None. On generated 'pillar' seed 0 a hypothesis of three right pairs, fitted
    to paths near one side of the overlap, was 17 px off (median over the shared ground) and
    took no later pair within its gates; refitted with a newcomer's four candidates it held
    five pairs and was 5.4 px off."""
    if not hypothesis.markers:
        return None
    used_a = {a for a, _ in hypothesis.links}
    used_b = {b for _, b in hypothesis.links}
    x_a = np.array([m.x_a for m in hypothesis.markers])
    x_b = np.array([m.x_b for m in hypothesis.markers])
    index = _PairIndex.of_pool(pool)  # once: each refit's support reuses it
    gates = pool.gates_px(cfg)
    best: tuple[np.ndarray, list[tuple[int, int]], np.ndarray] | None = None
    for k, (a_label, b_label) in enumerate(index.pairs.tolist()):
        mine = index.rows(k)
        rows = mine[new[mine]]
        if a_label in used_a or b_label in used_b or len(rows) < cfg.comotion_confirm_support:
            continue
        H = fit(np.r_[x_a, pool.x_a[rows]], np.r_[x_b, pool.x_b[rows]])
        if H is None:
            continue
        chosen, inliers = _chosen_rows(index, errors(H, pool.x_a, pool.x_b) < gates, index.n,
                                       cfg, cfg.comotion_min_support)
        if {(a_label, b_label), *hypothesis.links} <= set(chosen) and (
                best is None or inliers.sum() > best[2].sum()):
            best = (H, chosen, inliers)
    return None if best is None else _as_comotion(pool, *best, int(pool.frame.max()))


def markers_add(state: MarkerState, markers: Sequence[Marker], cfg: MarkerConfig) -> MarkerState:
    """The store with ``markers`` added (oldest first, one per grid cell, newest wins)."""
    cells = dict(state.cells)
    for m in sorted(markers, key=lambda m: m.frame):
        cells[_cell(m.x_a, state.size_a, cfg)] = m
    return replace(state, cells=cells, n_dropped=state.n_dropped + len(markers))
