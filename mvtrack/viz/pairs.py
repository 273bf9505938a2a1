"""Pair layers: FOV events and lines, Hough accumulators, markers, projections, homography.

Reads the pair stage's :class:`~mvtrack.stages.pair.PairResult` (duck-typed: the viewer only
reads its documented fields) and logs through a :class:`~mvtrack.viz.sink.RerunSink`.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping, Sequence
from functools import partial
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np
import rerun as rr

from mvtrack.pipeline import FrameResult
from mvtrack.stages.targets import SIDES
from mvtrack.viz import paths
from mvtrack.viz.log import line_strip_in_frame, ring_strips, strips_key, to_viewer

if TYPE_CHECKING:
    from mvtrack.viz.sink import RerunSink

__all__ = ["homographies_to_reference", "hough_image", "hough_mosaic", "log_pair"]

_TILE_W, _TILE_H = 180, 120  # one accumulator in the mosaic, mosaic pixels
_CUE_RADIUS_PX = 8.0  # hollow ring radius of projected targets, viewer pixels
_NEAR_FRAME_FRAC = 0.1  # projections drawn up to this fraction of the frame outside it
_NAME_AT = 0.1  # an FOV line's name: this fraction of the way along it from its lower end


def _valid_H(pr: Any) -> np.ndarray | None:
    est = getattr(pr, "homography", None)
    return np.asarray(est.H_b_from_a, np.float64) if est else None


def homographies_to_reference(ref: str, pairs: Mapping[tuple[str, str], Any]
                              ) -> dict[str, np.ndarray]:
    """Camera -> (3,3) H_ref_from_cam for ``ref`` itself and every camera joined to it by a
    chain of pairs with a valid H (A-C and C-B map B through C when A and B do not overlap);
    the chain with the fewest pairs is used."""
    valid = {key: H for key, pr in pairs.items() if (H := _valid_H(pr)) is not None}
    out = {ref: np.eye(3)}
    while True:  # one more pair per round: the first chain found is a shortest one
        found = {}
        for (a, b), H in valid.items():
            if a in out and b not in out:
                found[b] = out[a] @ np.linalg.inv(H)
            elif b in out and a not in out:
                found[a] = out[b] @ H
        if not found:
            return out
        out.update(found)


def hough_image(accumulator: np.ndarray) -> np.ndarray:
    """(n_theta, n_rho) votes -> (n_theta, n_rho, 3) uint8 BGR, inferno, scaled to the max."""
    acc = np.asarray(accumulator, np.float64)
    top = float(acc.max()) if acc.size else 0.0
    u8 = np.zeros(acc.shape, np.uint8) if top <= 0 else (255.0 * acc / top).astype(np.uint8)
    return cv2.applyColorMap(u8, cv2.COLORMAP_INFERNO)


def _feet_of(result: FrameResult, cam: str, label: int) -> np.ndarray | None:
    targets = result.cameras[cam].targets
    row = targets.index_of(label)
    return None if row is None else targets.feet[row]


def _log_events(sink: RerunSink, name: str, pr: Any, result: FrameResult) -> None:
    rec = sink.rec
    by_cam: dict[str, list[np.ndarray]] = {}
    for ev in pr.events:
        sink.event(f"{ev.camera}: FOV event t{ev.target} {ev.kind}s {ev.side} ({name})")
        xy = _feet_of(result, ev.camera, ev.target)
        if xy is not None:
            by_cam.setdefault(ev.camera, []).append(xy)
    for cam, feet in by_cam.items():
        # A white disc under the feet dot, a ring round it; what the event was is written in
        # the target's label (RerunSink._log_camera).
        sink.fov_event_cameras.add(cam)
        rec.log(paths.camera_layer(cam, "fov_events"), rr.Points2D(
            to_viewer(np.array(feet)), colors=(255, 255, 255), radii=6.0, draw_order=10.5))
    for a_label, b_label, ev in pr.associations:
        how = ("by co-motion (the bootstrap round)" if ev.kind == "comotion"
               else f"at a {ev.side} event of {ev.camera}")
        sink.event(f"pair {name}: linked t{a_label} ↔ t{b_label} {how}")


def _log_links(sink: RerunSink, key: tuple[str, str], pr: Any) -> None:
    now = set(pr.links)
    before = sink._links.get(key, set())
    for a_label, b_label in sorted(before - now):
        sink.event(f"pair {paths.pair_name(*key)}: link t{a_label} ↔ t{b_label} broken",
                   rr.TextLogLevel.DEBUG)
    sink._links[key] = now
    sink.rec.log(paths.pair_layer(*key, "links"), rr.Scalars(float(len(now))))


def _log_lines(sink: RerunSink, key: tuple[str, str], pr: Any, result: FrameResult) -> None:
    """Every learned FOV line, in the camera it is seen in, and re-estimated accumulators."""
    a, b = key
    strips: dict[str, list[np.ndarray]] = {a: [], b: []}
    labels: dict[str, list[str]] = {a: [], b: []}
    for slot in pr.slots:
        if slot.line is None:
            continue
        size = result.cameras[slot.seen_in].targets.size
        seg = line_strip_in_frame(slot.line.line, size)
        if seg is not None:
            strips[slot.seen_in].append(to_viewer(seg))
            labels[slot.seen_in].append(_line_name(slot.line))
    for cam in (a, b):
        other = b if cam == a else a
        shown = strips_key(strips[cam], labels[cam])  # the names follow from the lines
        sink.log_changed(paths.camera_pair_layer(cam, "fov_lines", other), shown,
                         partial(rr.LineStrips2D, strips[cam], colors=(0, 255, 255), radii=1.5,
                                 draw_order=8.0))
        sink.log_changed(paths.camera_pair_layer(cam, "fov_names", other), shown,
                         partial(_line_names, strips[cam], labels[cam]))
    if pr.reestimated:
        _log_hough(sink, key, pr)
        for idx, side in pr.reestimated:
            sink.event(f"pair {paths.pair_name(a, b)}: FOV line of {key[1 - idx]} {side} "
                       f"re-estimated in {key[idx]}", rr.TextLogLevel.DEBUG)


def _line_name(line: Any) -> str:
    """A FOV line's name, and what gave it unless the homography did: a line from the events
    alone can be far off, or stand for a border the camera does not see
    (:class:`~mvtrack.stages.fov.FovLine`)."""
    name = f"{line.edge_of} {line.side} edge"
    return name + {"events": f"\nfrom {line.events} events", "crossers": "\nfrom crossers",
                   "prior": "\nloaded"}.get(line.source, "")


def _line_names(strips: list[np.ndarray], labels: list[str]) -> rr.Points2D:
    """Each FOV line's name near its lower end, not at its middle (Rerun's place for a
    strip's label), where it covered the people walking across the line."""
    ends = [s[np.argsort(-s[:, 1])] for s in strips]
    at = np.array([s[0] + _NAME_AT * (s[1] - s[0]) for s in ends]).reshape(-1, 2)
    return rr.Points2D(at, labels=labels, colors=(0, 255, 255), radii=1.5, draw_order=8.0)


def hough_mosaic(key: tuple[str, str], slots: Sequence[Any]
                 ) -> tuple[np.ndarray, np.ndarray, list[str], np.ndarray, list[str]]:
    """All eight accumulators of a pair as one image, 2 rows (seen in A, in B) x 4 sides.

    Returns the (2*TILE_H, 4*TILE_W, 3) uint8 BGR mosaic, (K, 2) peak positions in mosaic
    pixels with their labels, and (8, 4) tile boxes (x, y, w, h) with their titles. A tile's
    rows are theta bins (0..pi, top to bottom), its columns rho bins (left: most negative).
    """
    mosaic = np.zeros((2 * _TILE_H, 4 * _TILE_W, 3), np.uint8)
    peaks: list[np.ndarray] = []
    peak_text: list[str] = []
    tiles, titles = [], []
    by_key = {(key.index(s.seen_in), s.side): s for s in slots}
    for row, seen_in in enumerate(key):
        for col, side in enumerate(SIDES):
            x0, y0 = col * _TILE_W, row * _TILE_H
            slot = by_key.get((row, side))
            n = 0 if slot is None else slot.n_events
            tiles.append((x0, y0, _TILE_W, _TILE_H))
            titles.append(f"{key[1 - row]} {side} in {seen_in} ({n} ev)")
            h = None if slot is None else slot.hough
            if h is None or np.asarray(h.accumulator).size == 0:
                continue
            acc = np.asarray(h.accumulator, np.float64)
            tile = cv2.resize(hough_image(acc), (_TILE_W, _TILE_H),
                              interpolation=cv2.INTER_NEAREST)
            mosaic[y0:y0 + _TILE_H, x0:x0 + _TILE_W] = tile
            pk = np.asarray(h.peaks, np.float64).reshape(-1, 3)
            thetas, rhos = np.asarray(h.thetas_rad), np.asarray(h.rhos_px)
            if len(pk) and len(thetas) > 1 and len(rhos) > 1:
                ti = np.interp(pk[:, 0], thetas, np.arange(len(thetas)))
                ri = np.interp(pk[:, 1], rhos, np.arange(len(rhos)))
                peaks.append(np.c_[x0 + (ri + 0.5) * _TILE_W / len(rhos),
                                   y0 + (ti + 0.5) * _TILE_H / len(thetas)])
                peak_text += [f"{v:.0f}" for v in pk[:, 2]]
    pts = np.concatenate(peaks) if peaks else np.zeros((0, 2))
    return mosaic, pts, peak_text, np.array(tiles, np.float64), titles


def _log_hough(sink: RerunSink, key: tuple[str, str], pr: Any) -> None:
    a, b = key
    mosaic, pts, text, tiles, titles = hough_mosaic(key, pr.slots)
    ok, buf = cv2.imencode(".jpg", mosaic, [cv2.IMWRITE_JPEG_QUALITY, 85])
    if ok:
        sink.rec.log(paths.hough_accumulators(a, b),
                     rr.EncodedImage(contents=buf.tobytes(), media_type="image/jpeg"))
    sink.rec.log(paths.hough_peaks(a, b), rr.Points2D(pts, labels=text, colors=(0, 255, 0),
                                                      radii=2.5))
    sink.rec.log(paths.hough_tiles(a, b), rr.Boxes2D(
        array=tiles, array_format=rr.Box2DFormat.XYWH, colors=(200, 200, 200), radii=0.5))
    sink.rec.log(paths.hough_titles(a, b), rr.Points2D(
        tiles[:, :2] + [_TILE_W / 2, 2.0], labels=titles, radii=0.1, colors=(230, 230, 230)))


def _log_markers(sink: RerunSink, key: tuple[str, str], pr: Any) -> None:
    a, b = key
    markers = pr.markers.markers
    xa = np.array([m.x_a for m in markers], np.float64).reshape(-1, 2)
    xb = np.array([m.x_b for m in markers], np.float64).reshape(-1, 2)
    for cam, other, pts in ((a, b, xa), (b, a, xb)):  # the store changes on marker frames only
        sink.log_changed(paths.camera_pair_layer(cam, "markers", other), pts.tobytes(),
                         partial(rr.Points2D, to_viewer(pts), colors=(255, 0, 255), radii=2.0,
                                 draw_order=7.0))
    sink.rec.log(paths.pair_layer(a, b, "markers"), rr.Scalars(float(len(markers))))
    if pr.markers.tried:  # why links gave no marker, so far (which test to look at)
        failed = sink.marker_rejections.setdefault(key, Counter())
        failed.update(reason for _, _, reason in pr.markers.rejected)
        for test in paths.MARKER_TESTS:
            sink.rec.log(paths.marker_rejections(a, b, test), rr.Scalars(float(failed[test])))


def _log_homography(sink: RerunSink, key: tuple[str, str], pr: Any, result: FrameResult) -> None:
    a, b = key
    name = paths.pair_name(a, b)
    attempt = pr.attempt
    if attempt is not None:
        if attempt:
            sink.event(f"pair {name}: homography estimated from {attempt.n_markers} markers "
                       f"({attempt.method}), quality {attempt.quality_px:.2f} px")
        else:
            dropped = attempt.reason.startswith("dropped")
            sink.event(f"pair {name}: homography {'' if dropped else 'not estimated: '}"
                       f"{attempt.reason}",
                       rr.TextLogLevel.WARN if dropped else rr.TextLogLevel.DEBUG)
    H = _valid_H(pr)
    if H is None:  # nothing to project yet (an empty layer, so views and tests can rely on it)
        for src, dst in ((a, b), (b, a)):
            sink.log_changed(paths.camera_pair_layer(dst, "projected", src), b"",
                             partial(rr.LineStrips2D, []))
        return
    sink.rec.log(paths.pair_layer(a, b, "quality_px"), rr.Scalars(float(pr.homography.quality_px)))
    for src, dst, M in ((a, b, H), (b, a, np.linalg.inv(H))):
        t = result.cameras[src].targets
        metas = result.metas[src]
        hom = np.c_[t.feet, np.ones(len(t))] @ M.T
        ok = hom[:, 2] > 1e-9
        proj = np.full((len(t), 2), np.inf)
        proj[ok] = hom[ok, :2] / hom[ok, 2:3]
        w, h = result.cameras[dst].targets.size  # only what lands in (or near) dst's frame:
        mx, my = _NEAR_FRAME_FRAC * w, _NEAR_FRAME_FRAC * h  # far points would zoom the view out
        ok = (proj[:, 0] > -mx) & (proj[:, 0] < w + mx) & (proj[:, 1] > -my) & (proj[:, 1] < h + my)
        proj = proj[ok]
        seen = set(result.metas[dst].tolist())  # their own target's label already names them
        rings = [to_viewer(r) for r in ring_strips(proj, _CUE_RADIUS_PX)]
        labels = ["" if m in seen else f"m{m} from {src}" for m in metas[ok].tolist()]
        sink.log_changed(paths.camera_pair_layer(dst, "projected", src),
                         strips_key(rings, labels) + metas[ok].tobytes(),
                         partial(rr.LineStrips2D, rings, class_ids=metas[ok], labels=labels,
                                 radii=1.0, draw_order=9.0))
    _transfer_error(sink, key, H, result.index)


def _transfer_error(sink: RerunSink, key: tuple[str, str], H: np.ndarray, index: int) -> None:
    """Median transfer error of H on the true feet of people seen by both cameras."""
    truth = sink.truth
    if truth is None:
        return
    a, b = key
    ra = sink._truth_rows.get(a, {}).get(index)
    rb = sink._truth_rows.get(b, {}).get(index)
    if ra is None or rb is None:
        return
    ta, tb = truth.cameras[a], truth.cameras[b]
    common, ia, ib = np.intersect1d(ta.person[ra], tb.person[rb], return_indices=True)
    if len(common) == 0:
        return
    from mvtrack.stages.homography import transfer_errors

    err = transfer_errors(H, ta.foot[ra][ia], tb.foot[rb][ib])
    sink.rec.log(paths.transfer_error(a, b), rr.Scalars(float(np.median(err))))


def _links_text(links: Sequence[tuple[int, int]]) -> str:
    return ", ".join(f"t{a} ↔ t{b}" for a, b in links)


def bootstrap_text(name: str, round_: Any) -> str:
    """One line telling a co-motion bootstrap round (:class:`BootstrapRound`): what was pooled,
    what became of each held hypothesis, what the new search found and what was accepted.
    A link reads "t<A label> ↔ t<B label>", as the pair's other links."""
    text = (f"pair {name}: co-motion round: {round_.candidates} candidates of "
            f"{round_.target_pairs} target pairs, {round_.supported_pairs} with enough to "
            f"follow a homography")
    for links, verdict in round_.verdicts:
        text += f"; held [{_links_text(links)}] {verdict}"
    if round_.found is not None:
        text += f"; search found [{_links_text(round_.found)}]"
    elif not round_.verdicts or round_.verdicts[-1][1] != "confirmed":
        text += f"; no homography that {round_.needed_pairs} of them follow"
    if round_.accepted is not None:
        text += f"; accepted [{_links_text(round_.accepted)}]"
    return text


def whole_run_h_text(name: str, found: Any, learned: bool, min_share: float) -> str:
    """One line telling what the whole-run labels did with a pair's whole-run co-motion
    search (``found``: its :class:`~mvtrack.stages.resolve.WholeRunH` or None; ``learned``:
    the run ended with a homography)."""
    text = f"whole-run labels: pair {name}: a co-motion search over the run"
    keep = "the labels use the run's final H" if learned else "the labels keep the run's links"
    if found is None:
        return f"{text} found no homography; {keep}"
    text += (f" links [{_links_text(found.hypothesis.links)}] "
             f"({len(found.hypothesis.markers)} candidates); of the targets its H puts inside "
             f"the other camera, {_share(found.found_share)} find one there")
    if learned:
        text += f" ({_share(found.final_share)} with the run's final H)"
    if found.used:
        return text + (": the labels use it instead" if learned else ": the labels use it")
    if not learned and (found.found_share or 0.0) < min_share:
        return f"{text}: under {min_share:.0%}, {keep}"
    return f"{text}: {keep}"


def refit_h_text(name: str, refit: Any) -> str:
    """One line telling how a pair's H fitted again from the whole-run labels came out
    (``refit``: its :class:`~mvtrack.stages.refit.RefitH`) and which H the run hands on."""
    text = f"whole-run labels: pair {name}: H fitted again from the labels' {refit.markers} markers"
    est = refit.estimate
    if not est:
        return f"{text} failed ({est.reason}); the H in use is handed on"
    text += (f", {int(est.inliers.sum())} inliers within {est.quality_px:.1f} px (median); of "
             f"the targets it puts inside the other camera, {_share(refit.found_share)} find "
             f"one there ({_share(refit.in_use_share)} with the H the labels used)")
    return text + (": handed on (pairs.json 'H_refit', --geometry)" if refit.used
                   else ": too few, the H in use is handed on")


def _share(share: float | None) -> str:
    return "none" if share is None else f"{share:.0%}"


def _log_bootstrap(sink: RerunSink, key: tuple[str, str], pr: Any) -> None:
    round_ = pr.bootstrap
    if round_ is None:
        return
    # a round like the last one (nobody new pooled, nothing held, found or accepted) is not
    # told again: a pair that waits for people logs a line when something changes. INFO, as
    # the viewer hides DEBUG: these lines are why a pair has no homography yet
    same = (round_.candidates, round_.target_pairs, round_.verdicts, round_.found,
            round_.accepted)
    sink.event_changed(f"bootstrap {paths.pair_name(*key)}", repr(same).encode(),
                       bootstrap_text(paths.pair_name(*key), round_))


def log_pair(sink: RerunSink, key: tuple[str, str], pr: Any, result: FrameResult) -> None:
    """Every layer of pair ``key`` = (A, B) at this frame."""
    name = paths.pair_name(*key)
    _log_events(sink, name, pr, result)
    _log_links(sink, key, pr)
    _log_lines(sink, key, pr, result)
    _log_markers(sink, key, pr)
    _log_bootstrap(sink, key, pr)
    _log_homography(sink, key, pr, result)
