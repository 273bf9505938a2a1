"""Every Rerun entity path mvtrack logs, defined here and nowhere else.

The paths are a stable, documented contract: blueprints, tests and users' saved layouts refer to
them. Change one only with a note in the changelog.

Static (logged once per recording)::

    /clip                           TextDocument  the clip's description and mvtrack's version
    /params                         TextDocument  the thresholds used, as TOML; AnyValues: each
                                                  threshold as "stage.name" = value
    /cameras                        AnnotationContext  class id = meta id -> "meta N", its colour

Per camera ``cam``, in that camera's pixel space (one 2D view overlays them)::

    /cameras/{cam}/image            EncodedImage (JPEG) or Image (lossless): the frame
    /cameras/{cam}/background       EncodedImage or Image: the background B (every N frames)
    /cameras/{cam}/distance         EncodedImage: D_B in [0, 1] as gray (black 0, white 1)
    /cameras/{cam}/masks            SegmentationImage: 1 MVO, 2 ghost, 3 foreground shadow,
                                    4 ghost shadow, 5 border mover (legend: its own
                                    AnnotationContext)
    /cameras/{cam}/labels           SegmentationImage: each target's pixels hold its meta id
    /cameras/{cam}/blobs            Boxes2D + AnyValues: candidate blobs, hover shows area_px,
                                    area_threshold_px (T_area at the blob's row), max_distance,
                                    mean_flow_px, is_mvo, border_mover
    /cameras/{cam}/heights          LineStrips2D + AnyValues: per MVO below the top border, a
                                    line from its top edge down to the feet row the size model
                                    puts under a head there (where its legs are regrown to):
                                    white from the line of whole people, gray from the
                                    least-squares line; hover shows predicted_height_px,
                                    box_height_px, whole_line
    /cameras/{cam}/targets          Boxes2D: target boxes, class id = meta,
                                    label "t{target} m{meta}", "· {enter|leave} {side}" added
                                    at a FOV event
    /cameras/{cam}/feet             Points2D: feet, class id = meta
    /cameras/{cam}/axes             LineStrips2D: per target, its height axis from its feet up
                                    to its top (each mask's own PCA axis, or the camera's
                                    learned vertical with feet.up = "learned"), class id = meta
    /cameras/{cam}/truth            Boxes2D + AnyValues: the true people (truth clips only),
                                    green boxes; hover shows person, visible, in_frame (the
                                    fractions of the person seen and in the frame)
    /cameras/{cam}/truth_feet       Points2D: their true feet, green
    /cameras/{cam}/feet_final       Points2D: the feet `mvtrack track` writes to tracks.csv,
                                    smoothed over the run, logged for every frame once the run
                                    ends, class id = whole-run meta
    /cameras/{cam}/resolved         Boxes2D: whole-run labels, logged for every frame once the
                                    run ends, on the targets whose whole-run meta differs from
                                    their online one: class id = that meta, label "t{target} →
                                    m{meta}" (the labels `mvtrack track` writes to tracks.csv)
    /cameras/{cam}/fov_events       Points2D: white rings round the feet of targets at FOV events
                                    this frame (the event is in the target's label)
    /cameras/{cam}/fov_lines/{other}  LineStrips2D: the learned FOV lines of camera ``other``'s
                                    edges, seen in ``cam``
    /cameras/{cam}/fov_names/{other}  Points2D: each of those lines' name ("{other} {side}
                                    edge"), a tenth of the way up from its lower end
    /cameras/{cam}/markers/{other}  Points2D: the markers of pair (cam, other), cam's side
    /cameras/{cam}/projected/{other}  Points2D: ``other``'s targets projected into ``cam``
                                    through the pair's homography, class id = meta
    /cameras/{cam}/cues             LineStrips2D: metas expected in ``cam`` but unseen, as hollow
                                    rings at their projections, class id = meta

Per overlapping pair ``a-b`` (names in the clip's overlap order)::

    /pairs/{a}-{b}/hough/accumulators  EncodedImage: the pair's eight Hough accumulators as one
                                    mosaic, row 0 lines seen in a, row 1 seen in b, columns the
                                    sides left, right, top, bottom; in a tile rows are theta bins
                                    (0..pi downwards), columns rho bins (logged at re-estimates)
    /pairs/{a}-{b}/hough/peaks      Points2D: the accumulators' peaks, labelled with their votes
    /pairs/{a}-{b}/hough/tiles      Boxes2D: the tiles' outlines
    /pairs/{a}-{b}/hough/titles     Points2D: the tiles' titles "{edge_of} {side} in {seen_in}"
    /pairs/{a}-{b}/quality_px       Scalars: median symmetric transfer error of the markers
    /pairs/{a}-{b}/markers          Scalars: markers in the store
    /pairs/{a}-{b}/links            Scalars: linked target pairs (FOV associations alive)
    /pairs/{a}-{b}/markers_rejected/{test}  Scalars: links whose marker failed ``test``
                                    (outside, height, no_motion: SPEC §5's tests a, b, c) so
                                    far, logged on marker frames
    /pairs/{a}-{b}/costs            TextDocument: the matcher's cost matrix (symmetric transfer
                                    distance in body heights, A targets x B targets)

Ground-plane map (reference camera's pixels, or metres with ``truth/ground.json``; a camera
that does not overlap the reference joins through the shortest chain of pairs with a valid H),
drawn around the feet seen so far, within the reference camera's outline plus two outline
sizes on every side (a poor learned homography would otherwise throw points hundreds of metres
away and zoom the map out)::

    /ground/fov/{cam}               LineStrips2D: camera ``cam``'s frame outline on the ground
                                    (the parts inside the map's extent)
    /ground/targets                 Points2D: every target's ground point inside the extent,
                                    class id = meta
    /ground/trails                  LineStrips2D: each live meta-target's recent ground track
    /ground/truth                   Points2D: true positions (metres, truth clips only)

Events and metrics::

    /events                         TextLog: FOV events, associations, homography estimates,
                                    tracker births/splits/merges/retirements, fragments
                                    absorbed, group cuts, hidden merged targets, warnings
    /metrics/targets/{cam}          Scalars: targets in ``cam``
    /metrics/stage_ms/{stage}       Scalars: milliseconds per stage (all cameras)
    /metrics/log_ms                 Scalars: milliseconds spent logging the frame
    /metrics/foot_error_px/{cam}    Scalars: mean foot error vs truth (truth clips only)
    /metrics/transfer_error_px/{a}-{b}  Scalars: median transfer error of H on true feet
    /metrics/summary                AnyValues: a run's summary figures: frames, pipeline_fps,
                                    foot_error_px.{cam}; with truth idf1_global, consistency
                                    (and *_online) of the labels (``--watch`` compares them)

Coordinates: Rerun draws pixel (0, 0) over [0, 1] x [0, 1]; mvtrack's pixel centres are at integer
coordinates (FORMATS.md), so every point, box and line is logged shifted by +0.5 px.

Timelines: ``frame`` (sequence: the clip frame index) and ``clip_time`` (duration: frame / fps).
"""

from __future__ import annotations

__all__ = [
    "CAMERAS",
    "CLIP",
    "EVENTS",
    "FRAME_TIMELINE",
    "GROUND",
    "GROUND_TARGETS",
    "GROUND_TRAILS",
    "GROUND_TRUTH",
    "MASK_LAYER",
    "METRICS",
    "PARAMS",
    "SUMMARY",
    "TIME_TIMELINE",
    "camera",
    "camera_layer",
    "camera_pair_layer",
    "foot_error",
    "ground_fov",
    "hough",
    "hough_accumulators",
    "hough_peaks",
    "hough_tiles",
    "hough_titles",
    "log_ms",
    "pair",
    "pair_costs",
    "pair_layer",
    "pair_name",
    "stage_ms",
    "targets_metric",
    "transfer_error",
]

FRAME_TIMELINE = "frame"
TIME_TIMELINE = "clip_time"

CLIP = "/clip"
PARAMS = "/params"
CAMERAS = "/cameras"
GROUND = "/ground"
GROUND_TARGETS = "/ground/targets"
GROUND_TRUTH = "/ground/truth"
GROUND_TRAILS = "/ground/trails"
EVENTS = "/events"
METRICS = "/metrics"
SUMMARY = "/metrics/summary"

CAMERA_LAYERS = (
    "image", "background", "distance", "masks", "labels", "blobs", "heights", "targets", "feet",
    "axes", "truth", "truth_feet", "feet_final", "resolved", "fov_events", "cues",
)
"""Layers of a camera that have no second camera in their path."""

CAMERA_PAIR_LAYERS = ("fov_lines", "fov_names", "markers", "projected")
"""Layers of a camera drawn from a pair: ``/cameras/{cam}/{layer}/{other}``."""

PAIR_LAYERS = ("quality_px", "markers", "links")
"""Scalar series of a pair: ``/pairs/{a}-{b}/{layer}``."""

MASK_LAYER = {1: "MVO", 2: "ghost", 3: "foreground shadow", 4: "ghost shadow",
              5: "border mover"}
"""Class ids of ``/cameras/{cam}/masks``."""


def camera(cam: str) -> str:
    """``/cameras/{cam}``: the root of one camera's pixel space."""
    return f"{CAMERAS}/{cam}"


def camera_layer(cam: str, layer: str) -> str:
    """``/cameras/{cam}/{layer}`` for a layer of :data:`CAMERA_LAYERS`."""
    if layer not in CAMERA_LAYERS:
        raise ValueError(f"unknown camera layer {layer!r}")
    return f"{CAMERAS}/{cam}/{layer}"


def camera_pair_layer(cam: str, layer: str, other: str) -> str:
    """``/cameras/{cam}/{layer}/{other}`` for a layer of :data:`CAMERA_PAIR_LAYERS`."""
    if layer not in CAMERA_PAIR_LAYERS:
        raise ValueError(f"unknown camera pair layer {layer!r}")
    return f"{CAMERAS}/{cam}/{layer}/{other}"


def pair_name(a: str, b: str) -> str:
    """``a-b``: a pair's name in paths."""
    return f"{a}-{b}"


def pair(a: str, b: str) -> str:
    """``/pairs/{a}-{b}``."""
    return f"/pairs/{pair_name(a, b)}"


def pair_layer(a: str, b: str, layer: str) -> str:
    """``/pairs/{a}-{b}/{layer}`` for a layer of :data:`PAIR_LAYERS`."""
    if layer not in PAIR_LAYERS:
        raise ValueError(f"unknown pair layer {layer!r}")
    return f"{pair(a, b)}/{layer}"


MARKER_TESTS = ("outside", "height", "no motion")
"""The marker tests, as the pair stage's ``MarkerResult.rejected`` names the one a link failed."""


def marker_rejections(a: str, b: str, test: str = "") -> str:
    """``/pairs/{a}-{b}/markers_rejected``, or the series of one of :data:`MARKER_TESTS`
    (spaces written as underscores: ``.../no_motion``)."""
    if test and test not in MARKER_TESTS:
        raise ValueError(f"unknown marker test {test!r}")
    return f"{pair(a, b)}/markers_rejected" + (f"/{test.replace(' ', '_')}" if test else "")


def pair_costs(a: str, b: str) -> str:
    """``/pairs/{a}-{b}/costs``: the matcher's cost matrix."""
    return f"{pair(a, b)}/costs"


def hough(a: str, b: str) -> str:
    """``/pairs/{a}-{b}/hough``: the root of a pair's Hough mosaic."""
    return f"{pair(a, b)}/hough"


def hough_accumulators(a: str, b: str) -> str:
    """``/pairs/{a}-{b}/hough/accumulators``."""
    return f"{hough(a, b)}/accumulators"


def hough_peaks(a: str, b: str) -> str:
    """``/pairs/{a}-{b}/hough/peaks``."""
    return f"{hough(a, b)}/peaks"


def hough_titles(a: str, b: str) -> str:
    """``/pairs/{a}-{b}/hough/titles``."""
    return f"{hough(a, b)}/titles"


def hough_tiles(a: str, b: str) -> str:
    """``/pairs/{a}-{b}/hough/tiles``."""
    return f"{hough(a, b)}/tiles"


def ground_fov(cam: str) -> str:
    """``/ground/fov/{cam}``: the outline of ``cam``'s frame on the ground plane."""
    return f"{GROUND}/fov/{cam}"


def targets_metric(cam: str) -> str:
    """``/metrics/targets/{cam}``."""
    return f"{METRICS}/targets/{cam}"


def stage_ms(stage: str) -> str:
    """``/metrics/stage_ms/{stage}``."""
    return f"{METRICS}/stage_ms/{stage}"


def log_ms() -> str:
    """``/metrics/log_ms``: the cost of logging one frame."""
    return f"{METRICS}/log_ms"


def foot_error(cam: str) -> str:
    """``/metrics/foot_error_px/{cam}``."""
    return f"{METRICS}/foot_error_px/{cam}"


def transfer_error(a: str, b: str) -> str:
    """``/metrics/transfer_error_px/{a}-{b}``."""
    return f"{METRICS}/transfer_error_px/{pair_name(a, b)}"
