"""Sakbot background subtraction (SPEC §1, thesis §3.2.1; Cucchiara et al.).

    state = train_background(training_frames, "rgb", cfg)   # their per-pixel median
    for frame in frames:
        state, result = background_step(state, frame, cfg)  # result.mvo_labels -> tracker

Per frame, against the current background B:

1. HSV planes of the frame (OpenCV ``HSV_FULL``: hue 0..255 for [0, 2π), S and V 0..255 for
   [0, 1]); gray cameras have V (the gray level) only.
2. Shadow map (thesis eq. 3.1): α ≤ I_V/B_V ≤ β, |I_S − B_S| ≤ τ_S, circular |ΔH| ≤ τ_H.
3. D_B = max(circular |ΔH|/π, |ΔS|, |ΔV|); candidates D_B > T_L, opened, shadows removed;
   8-connected components are the blobs.
4. A blob is an MVO when area > T_area, max D_B > T_H and mean optical flow > T_AOF; the other
   blobs are ghosts. Shadow pixels 8-connected to an MVO (through shadow) are foreground shadows
   (across small gaps: below).
5. Selective update: the frame with MVO and foreground-shadow pixels replaced by B is pushed into
   the FIFO; the new B is the median of n FIFO frames spaced m apart (the newest and every m-th
   older one). Ghosts are not masked, so the median absorbs them (but see border movers below).

Choices beyond the thesis (each with its config field):

- **Training spread over time.** B starts as the median of ``train_frames`` frames taken
  ``train_spacing_frames`` apart from the start (:func:`training_offsets`), not of the first
  ``train_frames`` in a row: a walker slower than a body width per ``train_frames / 2`` frames
  covers a pixel in most of a short run and is learned as background, and its ghost trail then
  joins the people who pass it (stacked fragments, one blob) and is never absorbed. The
  training frames also give a first size model (``train_sizes``, :func:`train_background`):
  it holds T_area for far people until the run has learned its own.
- **Colour needs light.** S is noise on dark pixels and hue on nearly gray ones (PETS: gray
  pavement). The S terms (of D_B and the shadow test) apply only where I and B both have
  V > ``colour_min_value``, the hue terms only where both also have S > ``hue_min_sat``;
  elsewhere V (and S) carry the test.
- **Exact 8-bit arithmetic.** Every threshold is applied to the 8-bit planes in an exactly
  equivalent integer form (e.g. α ≤ I_V/B_V ⟺ I_V ≥ ⌈α·B_V⌉), with the bounds precomputed once per
  background. ``distance`` is the 8-bit D_B / 255 (hue: circular 8-bit difference × 2, so hue has
  the 1.4° resolution of OpenCV's 8-bit hue).
- **Average flow.** T_AOF is compared with the magnitude of the blob's *mean flow vector*: the
  mean of per-pixel magnitudes is biased up by noise (0.2-0.45 px/frame on a static textured
  ghost in the tests), while the mean vector averages the noise out and keeps a walker's motion.
- **Flow only where it matters.** Mean flow per blob comes from DIS optical flow (OpenCV,
  ultrafast preset) on frames downscaled so their width is at most ``flow_max_width_px`` (1.2 ms
  at 384×288, against 140 ms for full-frame Farneback); it is skipped when there are no blobs.
  The first step after training has no previous frame: its mean flows are NaN and the flow test
  is skipped for that frame only.
- **Legs grown back.** Dark gray trousers on gray pavement pass the shadow test, and thin
  lower legs fall apart into fragments that the opening removes: the MVO ends at the hips or
  knees. Where the camera's size line (learned from its own MVOs) predicts the feet row,
  shadow and D_B > T_L pixels growing down from the torso within a corridor below it are given
  back to the MVO (:func:`_regrow_legs`, ``regrow_legs``); the shadow map and the foreground
  shadows are then taken without them. An MVO cut by the top border has no head there, so
  the size line puts its feet too low and its cast shadow would become its legs: if its legs
  were mostly all there while it was below the border (a score carried from MVO to
  overlapping MVO, ``legs_score_decay``), it gets legs grown only where they vanish at once,
  and only down to where they last reached.
- **Broken shadows stay foreground.** A far person's cast shadow passes the shadow test in
  specks (texture, noise, the legs between): unconnected to the MVO, they were ghost shadows,
  went into the FIFO, and a slow walker left a dark trail of its shadow in B. A shadow pixel
  reaches an MVO across gaps of up to ``fg_shadow_gap_px`` (:func:`_split_shadows`).
- **Border movers stay out of B.** A blob that passes every MVO test but T_area is not an MVO
  (the tracker never sees it) and, in the thesis, not kept out of the update either. A person
  entering slowly across a border stays under T_area for longer than the median needs (about
  n·m/2 frames), is learned as background meanwhile, and is a ghost once whole. Such blobs
  touching the frame border are kept out of the update (``keep_border_movers``); inside the
  frame they are left to the thesis's rule (pieces of people, whom the MVO hold covers).
- **FIFO length.** The newest frame and every m-th older one are the n samples, so the FIFO
  keeps (n − 1)·m + 1 frames (the thesis sizes it n·m; the extra frames are never selected).
- **Median.** Exact lower median (:mod:`mvtrack.stages.median`): 2.5 ms for n = 8 at 768×576×3.
  Consecutive medians of one spacing phase share n − 1 samples: a frame whose phase has no
  shared part stored computes ranks k−1 and k (k = (n − 1) // 2) of its n − 1 newest samples,
  stores them, and clamps the oldest sample between them; the frame m later clamps its newest
  sample between the stored pair (2 operations instead of the network). Same B, bit for bit,
  at about half the cost over the frames (``BackgroundState.shared``).

Immutability: inputs are never modified; arrays kept in the state (FIFO frames, background) are
read-only and shared with results only read-only; every other result array is new per call.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from functools import lru_cache

import cv2
import numpy as np

from mvtrack.params import BackgroundConfig
from mvtrack.stages.median import clamp, lower_median, order_statistics

__all__ = [
    "BackgroundResult",
    "BackgroundState",
    "BlobTable",
    "SizeModel",
    "background_step",
    "box_intersections",
    "feet_row",
    "link_groups",
    "min_area_at",
    "stacked_boxes",
    "too_tall_unions",
    "train_background",
    "training_offsets",
]

_MODALITIES = ("rgb", "gray")


@dataclass(frozen=True, eq=False)
class _Model:
    """A background B and what every frame compares against it (computed once per B).

    bgr: (H,W,3) or (H,W) uint8 B; h, s, v: (H,W) uint8 planes (h, s None for gray);
    ratio_lo, ratio_hi: (H,W) uint8, the I_V range with α ≤ I_V/B_V ≤ β (lo > hi where B_V = 0);
    colour: (H,W) bool, B_V > colour_min_value; hue_ok: B_S > hue_min_sat; shadow_hue_ok:
    B_S > shadow_hue_min_sat (all three None for gray)
    """

    bgr: np.ndarray
    h: np.ndarray | None
    s: np.ndarray | None
    v: np.ndarray
    ratio_lo: np.ndarray
    ratio_hi: np.ndarray
    colour: np.ndarray | None
    hue_ok: np.ndarray | None
    shadow_hue_ok: np.ndarray | None


@dataclass(frozen=True, eq=False)
class SizeModel:
    """A person's height in px against the image row of their feet, learned from MVOs.

    Far people are small: one T_area for the whole frame either drops them or lets in noise
    near the camera. Blobs shaped like a standing person (not touching the frame's sides,
    height / width in [size_min_aspect, size_max_aspect]) that are MVOs, or would be but for
    T_area, give samples (bottom row, height);
    a robust line height = slope * row + intercept through them (:func:`_fit_sizes`) lowers
    T_area for a blob to ``size_area_frac`` * (predicted height)^2 where that is smaller.
    While the samples' rows are too close together for a slope (people seen only far away, in
    one band of rows), the model is their median height near those rows (``band``).

    People whose legs pass the shadow test end at the hips, mostly far away where they are
    small: their samples are too short by a third to a half, and where they are most of a
    band of rows they pull ``line`` down there and its slope up (generated 'tilted' s2 cam1,
    frame 215: slope 0.56 for a truth of 0.32; 'pair' s2 cam1 0.44 for 0.19). ``whole`` is
    the line most samples lie within ``size_whole_tol`` of (:func:`_whole_line`): the height
    of someone seen whole, for the legs regrowth and the feet completion, which ask how tall
    a person is. T_area and the fragment rules keep ``line``, which errs small.

    samples:  (N, 2) float64 [bottom row (px edge), height px], newest last, read-only
    line:     (slope, intercept) of the current fit, or None (too few or too clustered samples)
    band:     (median height, first row, last row) while there is no line, or None
    whole:    (slope, intercept): the line of whole people, or None (no line, or no consensus)
    """

    samples: np.ndarray = field(default_factory=lambda: _readonly(np.zeros((0, 2))))
    line: tuple[float, float] | None = None
    band: tuple[float, float, float] | None = None
    whole: tuple[float, float] | None = None

    def height_at(self, rows: np.ndarray) -> np.ndarray | None:
        """(K,) predicted person heights in px at the given bottom rows: the line's, else the
        band's median height on the band's rows (NaN on the others); None with neither."""
        r = np.asarray(rows, np.float64)
        if self.line is not None:
            return self.line[0] * r + self.line[1]
        if self.band is None:
            return None
        height, first, last = self.band
        return np.where((r >= first) & (r <= last), height, np.nan)

    def slope_intercept(self) -> tuple[float, float] | None:
        """The line, or the band as a flat line (check :meth:`height_at` for its rows)."""
        return self.line if self.line is not None or self.band is None else (0.0, self.band[0])

    def legs_line(self) -> tuple[float, float] | None:
        """The line the legs regrowth reads (:func:`_regrow_legs`): :attr:`whole`, else the
        line or band (:meth:`slope_intercept`); None with neither or a slope of 1 or more."""
        line = self.whole or self.slope_intercept()
        return line if line is not None and line[0] < 1.0 else None


def feet_row(line: tuple[float, float], top: np.ndarray) -> np.ndarray:
    """The feet rows (px edges) of whole people whose heads are at rows ``top`` (px edges) when
    height = slope * row + intercept (slope < 1): y_f solves y_f - top = slope * y_f +
    intercept."""
    slope, intercept = line
    return (np.asarray(top, np.float64) + intercept) / (1.0 - slope)


@dataclass(frozen=True, eq=False)
class BackgroundState:
    """Everything background subtraction carries from one frame to the next.

    modality:    "rgb" or "gray"
    fifo:        ((n-1)*m+1,) tuple of read-only frames, oldest first, with MVO and
                 foreground-shadow pixels replaced by the background of their time;
                 (H,W,3) uint8 BGR or (H,W) uint8 gray
    model:       the background B for the next frame and its derived planes
    recent_v:    up to ``flow_gap_frames`` previous frames' V planes at flow resolution, (h,w)
                 uint8, oldest first; empty before the first step
    frame_index: number of frames processed by :func:`background_step` so far
    mvo_prev:    (H,W) int32, read-only, or None before the first step: last frame's MVO labels
    mvo_ages:    (M,) int64, read-only: per last-frame MVO (label - 1), 1 + the frames in a row
                 its blob was held (1: it moved and had its full area)
    mvo_legs:    (M, 2) float64, read-only: per last-frame MVO (label - 1), its legs score
                 (above 0 when its legs were mostly all there while it was seen below the top
                 border, :func:`_regrow_legs`) and its bottom row
    mvo_merged:  (M,) bool, read-only: per last-frame MVO (label - 1), whether it is two or
                 more people's blobs run together (:func:`_merged_blobs`; all False with
                 ``size_skip_merged`` off)
    shared:      (m,) per one of the last m steps, oldest first: the read-only pair (ranks
                 k-1 and k of that step's n-1 newest FIFO samples, k = (n-1)//2) its phase's
                 next median reuses, or None; () means all None (n < 3 never stores any)
    sizes:       how tall people are at each image row, learned from this camera's MVOs
    prior_sizes: the same learned from the training frames (:func:`train_background`), or
                 None: it holds T_area until ``sizes`` has a model of its own
    """

    modality: str
    fifo: tuple[np.ndarray, ...]
    model: _Model
    recent_v: tuple[np.ndarray, ...]
    frame_index: int
    mvo_prev: np.ndarray | None = None
    mvo_ages: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    mvo_legs: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    mvo_merged: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    shared: tuple[tuple[np.ndarray, np.ndarray] | None, ...] = ()
    sizes: SizeModel = field(default_factory=SizeModel)
    prior_sizes: SizeModel | None = None

    @property
    def background(self) -> np.ndarray:
        """(H,W,3) or (H,W) uint8, read-only: the background B the next frame is compared with."""
        return self.model.bgr


@dataclass(frozen=True, eq=False)
class BlobTable:
    """Every candidate blob of one frame, as parallel arrays (K blobs, in label order).

    label:        (K,) int32, the blob's value in ``BackgroundResult.blob_labels`` (1..K)
    area_px:      (K,) int64, pixel count
    max_distance: (K,) float32, largest D_B in the blob, in [0, 1]
    mean_flow_px: (K,) float64, magnitude of the blob's mean optical-flow vector, px/frame
                  (NaN: no previous frame)
    changed_frac: (K,) float64, share of its pixels whose V changed over the flow gap (NaN: no
                  previous frame)
    edge_frame, edge_background: (K,) float64, mean |gradient of V| (central differences,
                  0..510) of the frame and of B on the blob's boundary pixels (NaN: test off)
    area_ok, strong_ok, flow_ok: (K,) bool, the thesis's three MVO tests (flow_ok is True
                  when NaN)
    moving_ok:    (K,) bool, flow_ok or changed_frac >= min_changed_frac, but never with
                  changed_frac under ``still_changed_frac`` (its flow is the neighbours')
    edge_ok:      (K,) bool, not a ghost by the edge test (True when the test is off)
    held:         (K,) bool, kept an MVO though not moving, or though under T_area (but above
                  ``hold_area_frac`` of it): it passes the other tests, overlaps last frame's
                  MVOs and has been held fewer than ``mvo_hold_frames`` frames in a row; a
                  small one must be the largest piece of a last-frame MVO that no full-size
                  MVO overlaps
    is_mvo:       (K,) bool, (area_ok & strong_ok & edge_ok & moving_ok) | held
    border_mover: (K,) bool, not an MVO but strong_ok & edge_ok & moving_ok (so under T_area)
                  and touching the frame border: someone coming in or going out piece by piece;
                  not tracked, and kept out of B's update with ``keep_border_movers``
    mvo_label:    (K,) int32, the blob's value in ``mvo_labels`` (0 for ghosts)
    box_xywh:     (K, 4) float64, bounding box; x, y are the left/top pixel edges (col - 0.5)
    min_area_px:  float, the T_area this frame size used (:func:`min_area_at`)
    area_threshold_px: (K,) float64, the T_area each blob was held to: ``min_area_px``, or
                  lower where the camera's :class:`SizeModel` expects people to be small
    """

    label: np.ndarray
    area_px: np.ndarray
    max_distance: np.ndarray
    mean_flow_px: np.ndarray
    changed_frac: np.ndarray
    edge_frame: np.ndarray
    edge_background: np.ndarray
    area_ok: np.ndarray
    strong_ok: np.ndarray
    flow_ok: np.ndarray
    moving_ok: np.ndarray
    edge_ok: np.ndarray
    held: np.ndarray
    is_mvo: np.ndarray
    border_mover: np.ndarray
    mvo_label: np.ndarray
    box_xywh: np.ndarray
    min_area_px: float = 0.0
    area_threshold_px: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __len__(self) -> int:
        return len(self.label)


@dataclass(frozen=True, eq=False)
class BackgroundResult:
    """One camera, one frame of background subtraction; all masks (H,W).

    frame_index:    0-based index of this frame among the steps since training
    background_bgr: (H,W,3) uint8 BGR (gray: (H,W) uint8), read-only: the B used for this frame
    distance_u8:    uint8, D_B x 255 rounded down (as the stage computes and thresholds it;
                    :attr:`distance` is the float32 view in [0, 1])
    shadow:         bool, the shadow map: pixels passing the shadow test, but legs grown back
    candidate:      bool, D_B > T_L after the opening, shadows removed
    blob_labels:    int32, 0 none, 1..K the candidate blobs (rows of ``blobs``)
    mvo_labels:     int32, 0 none, 1..M the MVO blobs, consecutive in blob-label order, with
                    the legs grown back (:func:`_regrow_legs`; those may lie outside
                    ``candidate``)
    ghost_mask:     bool, pixels of candidate blobs that are neither MVOs nor border movers
    border_mover_mask: bool, pixels of the border movers (blobs under T_area that pass the
                    other tests and touch the frame border); with ``keep_border_movers`` B
                    does not learn them
    fg_shadow:      bool, shadow pixels connected (8-neighbourhood, through shadow) to an MVO
    ghost_shadow:   bool, the other shadow pixels
    blobs:          per-blob table
    sizes:          the camera's size model as this frame's legs regrowth read it (T_area
                    reads the training frames' while this one has no line or band yet)
    """

    frame_index: int
    background_bgr: np.ndarray
    distance_u8: np.ndarray
    shadow: np.ndarray
    candidate: np.ndarray
    blob_labels: np.ndarray
    mvo_labels: np.ndarray
    ghost_mask: np.ndarray
    border_mover_mask: np.ndarray
    fg_shadow: np.ndarray
    ghost_shadow: np.ndarray
    blobs: BlobTable
    sizes: SizeModel

    @property
    def mvo_mask(self) -> np.ndarray:
        """(H,W) bool, the MVO pixels."""
        return self.mvo_labels > 0

    @property
    def distance(self) -> np.ndarray:
        """(H,W) float32 in [0, 1], D_B (built on each access: the pipeline and the viewer use
        :attr:`distance_u8`)."""
        return np.multiply(self.distance_u8, np.float32(1.0 / 255.0), dtype=np.float32)


def _readonly(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


def _u8_floor(fraction: float, full: float = 255.0) -> int:
    """The integer k with  (x > fraction*full  ⟺  x > k)  for integer x."""
    return math.floor(fraction * full + 1e-9)


def _as_frame(frame: np.ndarray, modality: str) -> np.ndarray:
    """Check a frame and bring it to the modality's layout: BGR (H,W,3) or gray (H,W) uint8."""
    if frame.dtype != np.uint8:
        raise ValueError(f"background: frames must be uint8, got {frame.dtype}")
    if frame.ndim == 3 and frame.shape[2] == 3:
        return cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY) if modality == "gray" else frame
    if frame.ndim == 2 and modality == "gray":
        return frame
    raise ValueError(
        f"background: a {modality} frame must be (H,W,3) or gray (H,W), got shape {frame.shape}"
    )


def _model(bgr: np.ndarray, modality: str, cfg: BackgroundConfig) -> _Model:
    """Derive the per-B planes used by every frame's comparison."""
    bgr = _readonly(bgr)
    if modality == "gray":
        h = s = colour = hue_ok = shadow_hue_ok = None
        v = bgr
    else:
        h, s, v = cv2.split(cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV_FULL))
        colour = v > _u8_floor(cfg.colour_min_value)
        hue_ok = s > _u8_floor(cfg.hue_min_sat)
        shadow_hue_ok = s > _u8_floor(cfg.shadow_hue_min_sat)
    lo_lut, hi_lut = _ratio_luts(cfg.shadow_alpha, cfg.shadow_beta)
    return _Model(
        bgr=bgr,
        h=h,
        s=s,
        v=v,
        ratio_lo=cv2.LUT(v, lo_lut),
        ratio_hi=cv2.LUT(v, hi_lut),
        colour=colour,
        hue_ok=hue_ok,
        shadow_hue_ok=shadow_hue_ok,
    )


def _gradient_at(v: np.ndarray, index: np.ndarray) -> np.ndarray:
    """|V(x+1) - V(x-1)| + |V(y+1) - V(y-1)| (central differences, one-sided at the frame's
    border) of a (H,W) uint8 plane at flat pixel indices (P,) int64; (P,) int16 in 0..510."""
    height, width = v.shape
    flat = v.ravel()
    row, col = np.divmod(index, width)
    left, right = index - (col > 0), index + (col < width - 1)
    up, down = index - width * (row > 0), index + width * (row < height - 1)
    gx = np.abs(flat[right].astype(np.int16) - flat[left])
    gy = np.abs(flat[down].astype(np.int16) - flat[up])
    return gx + gy


@lru_cache(maxsize=8)
def _ratio_luts(alpha: float, beta: float) -> tuple[np.ndarray, np.ndarray]:
    """Per B_V value (0..255), the smallest and largest integer I_V with α ≤ I_V/B_V ≤ β.

    α ≤ I/B ⟺ I ≥ ⌈αB⌉ and I/B ≤ β ⟺ I ≤ ⌊βB⌋; B = 0 gets an empty range (lo 255 > hi 0).
    """
    b = np.arange(256, dtype=np.float64)
    lo = np.ceil(b * alpha - 1e-9)
    hi = np.floor(b * beta + 1e-9)
    lo[0], hi[0] = 255.0, 0.0
    return _readonly(lo.astype(np.uint8)), _readonly(hi.astype(np.uint8))


def _fifo_len(cfg: BackgroundConfig) -> int:
    return (cfg.fifo_n - 1) * cfg.fifo_spacing_frames + 1


def _flow_gray(value: np.ndarray, cfg: BackgroundConfig) -> np.ndarray:
    """The V plane (gray level, or HSV value) at optical-flow resolution (width at most
    ``flow_max_width_px``). V rather than luma saves a colour conversion; flow only needs
    texture that moves with the object."""
    gray = value
    factor = math.ceil(gray.shape[1] / cfg.flow_max_width_px)
    if factor <= 1:
        return gray
    size = (gray.shape[1] // factor, gray.shape[0] // factor)
    return cv2.resize(gray, size, interpolation=cv2.INTER_AREA)


def training_offsets(available: int, cfg: BackgroundConfig) -> np.ndarray:
    """(n,) int64 offsets from a run's first frame of the frames whose median is the initial
    background: ``train_frames`` of them, ``train_spacing_frames`` apart; a run too short for
    that spreads them evenly over its frames (all of them when it has at most ``train_frames``).
    available: frames in the run, >= 1."""
    if available < 1:
        raise ValueError(f"training_offsets: available = {available}, expected >= 1")
    n = min(cfg.train_frames, available)
    span = min((n - 1) * cfg.train_spacing_frames + 1, available)
    # span >= n, so the n points are at least 1 apart and round to distinct frames
    return np.linspace(0, span - 1, n).round().astype(np.int64)


def train_background(
    frames: Sequence[np.ndarray], modality: str, cfg: BackgroundConfig
) -> BackgroundState:
    """The initial state: B = per-pixel lower median of the first ``train_frames`` of
    ``frames`` (the frames at :func:`training_offsets` of the run).

    frames: BGR (H,W,3) uint8 or gray (H,W) uint8 (a gray camera may also be given BGR frames,
    which are converted). modality: "rgb" or "gray". The FIFO is filled with B.

    With ``train_sizes``, the training frames are also subtracted against B, in order, and
    the size model fitted to their MVOs is the state's ``prior_sizes`` [beyond]: until the
    run's own size model exists (``size_min_samples`` samples, 25-50 frames in), T_area for
    far people is then already theirs, not the frame's (generated 'three' cam2: 20 px walkers
    fell apart into pieces under T_area 100 for the first 26 frames).
    """
    if modality not in _MODALITIES:
        raise ValueError(f"train_background: modality {modality!r} must be 'rgb' or 'gray'")
    if len(frames) == 0:
        raise ValueError("train_background: no frames")
    used = [_as_frame(f, modality) for f in frames[: cfg.train_frames]]
    for i, f in enumerate(used):
        if f.shape != used[0].shape:
            raise ValueError(f"train_background: frame {i} is {f.shape}, frame 0 {used[0].shape}")
    model = _model(lower_median(used), modality, cfg)
    fifo = (model.bgr,) * _fifo_len(cfg)
    state = BackgroundState(modality=modality, fifo=fifo, model=model, recent_v=(), frame_index=0)
    if not cfg.train_sizes or cfg.size_area_frac <= 0:
        return state
    warm = state
    for frame in used:
        warm, _ = background_step(warm, frame, cfg)
    return replace(state, prior_sizes=_fit_sizes(warm.sizes.samples, used[0].shape[0], cfg))


def _hsv_planes(frame: np.ndarray, modality: str) -> tuple[np.ndarray | None, ...]:
    if modality == "gray":
        return None, None, frame
    return tuple(cv2.split(cv2.cvtColor(frame, cv2.COLOR_BGR2HSV_FULL)))


def _distance_and_shadow(
    planes: tuple[np.ndarray | None, ...], model: _Model, cfg: BackgroundConfig
) -> tuple[np.ndarray, np.ndarray]:
    """D_B as uint8 (0..255 for [0, 1]) and the shadow map (bool), both (H,W)."""
    h, s, v = planes
    assert v is not None
    dist = cv2.absdiff(v, model.v)
    ratio_ok = (v >= model.ratio_lo) & (v <= model.ratio_hi)
    if (
        h is None
        or s is None
        or model.h is None
        or model.s is None
        or model.colour is None
        or model.hue_ok is None
        or model.shadow_hue_ok is None
    ):
        shadow = ratio_ok if cfg.gray_shadows else np.zeros_like(ratio_ok)
        return dist, shadow
    colour = model.colour & (v > _u8_floor(cfg.colour_min_value))  # S and H mean something
    ds = cv2.absdiff(s, model.s)
    np.multiply(ds, colour.view(np.uint8), out=ds)  # 0 where S means nothing (no masked store)
    dh = np.subtract(h, model.h)  # uint8 wraps: (h1 - h2) mod 256
    dh = np.minimum(dh, np.negative(dh))  # circular difference, 0..128 (128 = π)
    hue_ok = colour & model.hue_ok & (s > _u8_floor(cfg.hue_min_sat))
    hue_term = cv2.add(dh, dh)  # saturating: 0..255 for [0, π]
    np.multiply(hue_term, hue_ok.view(np.uint8), out=hue_term)
    dist = cv2.max(cv2.max(dist, ds), hue_term)
    sat_close = ds <= _u8_floor(cfg.shadow_sat_tol)  # true where S is not meaningful (ds = 0)
    shadow_hue_ok = colour & model.shadow_hue_ok & (s > _u8_floor(cfg.shadow_hue_min_sat))
    hue_close = ~shadow_hue_ok | (dh <= _u8_floor(cfg.shadow_hue_tol_rad, 128.0 / math.pi))
    return dist, ratio_ok & sat_close & hue_close


@dataclass(frozen=True, eq=False)
class _BlobPixels:
    """The candidate pixels: flat indices (P,) int64 and their blob labels (P,) int32."""

    index: np.ndarray
    label: np.ndarray


def _blob_pixels(index: np.ndarray, blob_labels: np.ndarray) -> _BlobPixels:
    """index: (P,) int64 flat indices of the candidate pixels."""
    return _BlobPixels(index=index, label=blob_labels.ravel()[index])


def _mvo_labels(
    pixels: _BlobPixels, blobs: BlobTable, shape: tuple[int, ...]
) -> tuple[np.ndarray, np.ndarray]:
    """The MVO label image (H,W) int32 and the flat indices of its pixels."""
    lut = np.concatenate([np.zeros(1, np.int32), blobs.mvo_label])
    values = lut[pixels.label]
    keep = values > 0
    mvo_labels = np.zeros(shape, np.int32)
    mvo_index = pixels.index[keep]
    mvo_labels.ravel()[mvo_index] = values[keep]
    return mvo_labels, mvo_index


def _blob_mask(pixels: _BlobPixels, chosen: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """(H,W) bool, the pixels of the blobs with ``chosen`` (K,) bool set."""
    mask = np.zeros(shape, bool)
    if chosen.any():
        pick = np.concatenate([[False], chosen])[pixels.label]
        mask.ravel()[pixels.index[pick]] = True
    return mask


@dataclass(frozen=True, eq=False)
class _Motion:
    """What the motion tests read: DIS flow (h,w,2) float32 px/frame and the changed map (h,w)
    bool at flow resolution (``factor`` full-resolution px per flow px); None on the first
    step after training."""

    flow: np.ndarray | None
    changed: np.ndarray | None
    factor: int


def _blob_motion(
    pixels: _BlobPixels, area: np.ndarray, width: int, motion: _Motion
) -> tuple[np.ndarray, np.ndarray]:
    """Per blob (labels 1..K, area (K,)): the magnitude of the mean flow vector (px/frame) and
    the share of changed pixels; NaN without a previous frame."""
    k = len(area)
    if motion.flow is None or motion.changed is None:
        return np.full(k, np.nan), np.full(k, np.nan)
    idx, lab, f = pixels.index, pixels.label, motion.factor
    rows = np.minimum(idx // width // f, motion.flow.shape[0] - 1)
    cols = np.minimum(idx % width // f, motion.flow.shape[1] - 1)
    vectors = motion.flow[rows, cols]  # (P, 2)
    area = np.maximum(area, 1)
    sum_x = np.bincount(lab, weights=vectors[:, 0], minlength=k + 1)[1:]
    sum_y = np.bincount(lab, weights=vectors[:, 1], minlength=k + 1)[1:]
    changed = np.bincount(lab, weights=motion.changed[rows, cols], minlength=k + 1)[1:]
    return np.hypot(sum_x, sum_y) / area, changed / area


def _blob_edges(
    candidate: np.ndarray,
    blob_labels: np.ndarray,
    v_pair: tuple[np.ndarray, np.ndarray],
    k: int,
    cfg: BackgroundConfig,
) -> tuple[np.ndarray, np.ndarray]:
    """Per blob (labels 1..K): mean frame and background gradient (0..510) on its boundary
    (candidate pixels with a non-candidate 8-neighbour); NaN when the edge test is off."""
    if cfg.edge_ghost_ratio <= 0:
        return np.full(k, np.nan), np.full(k, np.nan)
    inner = cv2.erode(candidate.view(np.uint8), np.ones((3, 3), np.uint8)).view(bool)
    index = np.flatnonzero(candidate & ~inner)
    lab = blob_labels.ravel()[index]
    count = np.maximum(np.bincount(lab, minlength=k + 1)[1:], 1)
    frame_grad = _gradient_at(v_pair[0], index)
    bg_grad = _gradient_at(v_pair[1], index)
    frame = np.bincount(lab, weights=frame_grad, minlength=k + 1)[1:] / count
    background = np.bincount(lab, weights=bg_grad, minlength=k + 1)[1:] / count
    return frame, background


def _prev_overlaps(pixels: _BlobPixels, mvo_prev: np.ndarray | None) -> np.ndarray:
    """(P, 2) int64 distinct (blob label, last frame's MVO label) pairs that share a pixel."""
    if mvo_prev is None:
        return np.zeros((0, 2), np.int64)
    prev = mvo_prev.ravel()[pixels.index].astype(np.int64)
    hit = prev > 0
    if not hit.any():
        return np.zeros((0, 2), np.int64)
    span = int(prev.max()) + 1  # a count per (blob, MVO) key: linear, unlike sorting pairs
    keys = np.flatnonzero(np.bincount(pixels.label[hit].astype(np.int64) * span + prev[hit]))
    return np.c_[keys // span, keys % span]


def _hold_ages(overlaps: np.ndarray, mvo_ages: np.ndarray, k: int) -> np.ndarray:
    """(K,) int64: per blob, the smallest age (``BackgroundState.mvo_ages``) of the last-frame
    MVOs it overlaps (``overlaps`` from :func:`_prev_overlaps`); 0 when it overlaps none."""
    least = np.full(k, np.iinfo(np.int64).max)
    np.minimum.at(least, overlaps[:, 0] - 1, mvo_ages[overlaps[:, 1] - 1])
    least[least == np.iinfo(np.int64).max] = 0
    return least


def _merged_blobs(overlaps: np.ndarray, mvo_merged: np.ndarray, blobs: BlobTable,
                  sizes: SizeModel, tol: float) -> np.ndarray:
    """(K,) bool: per MVO blob, whether it is people's blobs run together: it overlaps two
    or more of last frame's MVOs, or it is the only MVO that overlaps one that was and is
    still taller than one person (by more than ``tol`` of the height ``sizes`` gives at its
    bottom row): until the group parts, its blob is still theirs. ``overlaps`` from
    :func:`_prev_overlaps`; ``mvo_merged``: :attr:`BackgroundState.mvo_merged`."""
    k = len(blobs.label)
    overlaps = overlaps[blobs.is_mvo[overlaps[:, 0] - 1]]
    blob, prev = overlaps[:, 0] - 1, overlaps[:, 1] - 1
    merged = np.bincount(blob, minlength=k)[:k] >= 2
    person = sizes.height_at(blobs.box_xywh[:, 1] + blobs.box_xywh[:, 3])
    if len(mvo_merged) and person is not None:
        with np.errstate(invalid="ignore"):  # NaN (no height there): not taller
            tall = blobs.box_xywh[:, 3] > (1.0 + tol) * person
        alone = np.bincount(prev, minlength=len(mvo_merged)) == 1
        kept = mvo_merged[prev] & alone[prev] & tall[blob]
        merged[blob[kept]] = True
    return merged


def _legs_before(overlaps: np.ndarray, mvo_legs: np.ndarray, k: int) -> np.ndarray:
    """(K, 2) float64: per blob, the highest legs score and the largest bottom row (lowest in
    the image) of the last-frame MVOs it overlaps (``BackgroundState.mvo_legs``;
    ``overlaps`` from :func:`_prev_overlaps`); (0, -1) when none."""
    before = np.full((k, 2), -np.inf)
    if len(mvo_legs):
        np.maximum.at(before, overlaps[:, 0] - 1, mvo_legs[overlaps[:, 1] - 1])
    before[np.isinf(before[:, 0])] = (0.0, -1.0)
    return before


def _small_remnants(small: np.ndarray, full: np.ndarray, area: np.ndarray,
                    overlaps: np.ndarray) -> np.ndarray:
    """(K,) bool: the ``small`` blobs that are all that is left of the last-frame MVOs they
    overlap: no ``full`` MVO of this frame overlaps any of those, and no larger small blob."""
    blob, prev = overlaps[:, 0] - 1, overlaps[:, 1]
    taken = np.zeros(int(prev.max(initial=0)) + 1, bool)
    taken[prev[full[blob]]] = True
    largest = np.zeros(len(taken), np.int64)  # per last-frame MVO, its largest small blob's area
    np.maximum.at(largest, prev[small[blob]], area[blob[small[blob]]])
    overlapping, beaten = np.zeros(len(small), bool), np.zeros(len(small), bool)
    overlapping[blob] = True
    beaten[blob[taken[prev] | (area[blob] < largest[prev])]] = True
    return small & overlapping & ~beaten


def _flow(prev: np.ndarray, cur: np.ndarray, factor: int) -> np.ndarray:
    """Dense DIS flow of the current frame's pixels, (h,w,2) float32 [dx, dy] in full-resolution
    px/frame: the pixel at x now was at x - flow(x) in ``prev``.

    Computed backwards (cur -> prev) so that it is indexed by *current* pixels: forward flow at
    a walker's current position would sample the background it has just covered (zero flow)."""
    dis = cv2.DISOpticalFlow.create(cv2.DISOPTICAL_FLOW_PRESET_ULTRAFAST)
    back = np.asarray(dis.calc(cur, prev, None))  # type: ignore[call-overload]
    return back * np.float32(-factor)


@dataclass(frozen=True, eq=False)
class _BlobEvidence:
    """Per-blob measurements (K,) that the MVO tests read (see :class:`BlobTable`)."""

    max8: np.ndarray
    mean_flow: np.ndarray
    changed_frac: np.ndarray
    edge_frame: np.ndarray
    edge_background: np.ndarray
    prev_overlaps: np.ndarray
    hold_age: np.ndarray


def min_area_at(shape: tuple[int, ...], cfg: BackgroundConfig) -> float:
    """T_area in pixels for frames of ``shape`` (H, W, ...): ``min_area_px``, grown in
    proportion to sqrt(H * W) above ``min_area_ref_size_px`` (never below ``min_area_px``)."""
    if cfg.min_area_ref_size_px <= 0:
        return float(cfg.min_area_px)
    size = math.sqrt(float(shape[0]) * float(shape[1]))
    return cfg.min_area_px * max(1.0, size / cfg.min_area_ref_size_px)


def _area_thresholds(stats: np.ndarray, sizes: SizeModel, min_area_px: float,
                     cfg: BackgroundConfig) -> np.ndarray:
    """(K,) T_area of each blob: ``min_area_px``, lowered to ``size_area_frac`` * h^2 where the
    size model predicts people of height h at the blob's bottom row (never below
    ``size_min_area_px``)."""
    k = stats.shape[0] - 1
    bottom = stats[1:, cv2.CC_STAT_TOP] + stats[1:, cv2.CC_STAT_HEIGHT]
    heights = sizes.height_at(bottom)
    if heights is None or cfg.size_area_frac <= 0:
        return np.full(k, min_area_px)
    scaled = cfg.size_area_frac * np.maximum(heights, 0.0) ** 2
    scaled = np.where(np.isnan(scaled), min_area_px, scaled)  # rows the model does not cover
    return np.clip(scaled, min(cfg.size_min_area_px, min_area_px), min_area_px)


def _inside(box_xywh: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """(K,) bool: the (K, 4) boxes (x, y at the pixel edges) touch no border of a frame of
    ``shape`` (none of their pixels is in the first or last row or column)."""
    x, y, w, h = box_xywh.T
    return (x > 0) & (y > 0) & (x + w < shape[1] - 1) & (y + h < shape[0] - 1)


def _blob_table(
    stats: np.ndarray, ev: _BlobEvidence, cfg: BackgroundConfig, min_area_px: float,
    thresholds: np.ndarray, shape: tuple[int, ...],
) -> tuple[BlobTable, np.ndarray]:
    """The blob table and each blob's new MVO age (K,) int64 (0 for ghosts); ``shape`` is the
    frame's."""
    k = stats.shape[0] - 1
    area = stats[1:, cv2.CC_STAT_AREA].astype(np.int64)
    area_ok = area > thresholds
    strong_ok = ev.max8 > _u8_floor(cfg.t_high)
    flow_ok = np.isnan(ev.mean_flow) | (ev.mean_flow > cfg.min_mean_flow_px)
    changed_ok = (cfg.min_changed_frac > 0) & (ev.changed_frac >= cfg.min_changed_frac)
    # DIS spreads a walker's flow over the still blob beside it (the ghost of a person who
    # stood there during training): a blob none of whose pixels changed does not move.
    still = ev.changed_frac < cfg.still_changed_frac  # NaN (no previous frame): False
    moving_ok = (flow_ok & ~still) | changed_ok
    with np.errstate(invalid="ignore"):
        edge_ok = ~(ev.edge_frame < cfg.edge_ghost_ratio * ev.edge_background)
    still_ok = area_ok & strong_ok & edge_ok
    in_hold = (ev.hold_age > 0) & (ev.hold_age <= cfg.mvo_hold_frames)
    full = still_ok & (moving_ok | in_hold)
    # What is left of a small tracked person (a torso whose legs and head came apart) stays
    # an MVO, unless it is a piece of someone still detected whole.
    small = ~area_ok & (area > cfg.hold_area_frac * thresholds) & strong_ok & edge_ok & in_hold
    held = (full & ~moving_ok) | _small_remnants(small, full, area, ev.prev_overlaps)
    is_mvo = (still_ok & moving_ok) | held
    age = np.where(held, ev.hold_age + 1, 1) * is_mvo
    mvo_label = np.zeros(k, np.int32)
    mvo_label[is_mvo] = np.arange(1, int(is_mvo.sum()) + 1, dtype=np.int32)
    box = stats[1:, :4].astype(np.float64)
    box[:, :2] -= 0.5
    table = BlobTable(
        label=np.arange(1, k + 1, dtype=np.int32),
        area_px=area,
        max_distance=ev.max8.astype(np.float32) / np.float32(255.0),
        mean_flow_px=ev.mean_flow,
        changed_frac=ev.changed_frac,
        edge_frame=ev.edge_frame,
        edge_background=ev.edge_background,
        area_ok=area_ok,
        strong_ok=strong_ok,
        flow_ok=flow_ok,
        moving_ok=moving_ok,
        edge_ok=edge_ok,
        held=held,
        is_mvo=is_mvo,
        border_mover=~is_mvo & strong_ok & edge_ok & moving_ok & ~_inside(box, shape),
        mvo_label=mvo_label,
        box_xywh=box,
        min_area_px=min_area_px,
        area_threshold_px=thresholds,
    )
    return table, age


def _split_shadows(shadow: np.ndarray, mvo: np.ndarray, mvo_index: np.ndarray,
                   gap_px: int) -> np.ndarray:
    """Foreground shadows: shadow pixels in an 8-connected component of (shadow | MVO), its
    parts joined across gaps of up to ``gap_px`` px (dilated by a (gap_px + 1)² square), that
    holds an MVO pixel. shadow, mvo: (H,W) bool; mvo_index: flat indices of the MVO pixels."""
    fg_shadow = np.zeros_like(shadow)
    shadow_index = np.flatnonzero(shadow)
    if len(mvo_index) == 0 or len(shadow_index) == 0:
        return fg_shadow
    union = (shadow | mvo).view(np.uint8)
    if gap_px:
        union = cv2.dilate(union, np.ones((gap_px + 1, gap_px + 1), np.uint8))
    n, comp = cv2.connectedComponentsWithAlgorithm(union, 8, cv2.CV_32S, cv2.CCL_GRANA)
    touching = np.zeros(n, bool)
    flat = comp.ravel()
    touching[flat[mvo_index]] = True
    fg_shadow.ravel()[shadow_index] = touching[flat[shadow_index]]
    return fg_shadow


def _regrow_legs(  # noqa: PLR0913 (the MVOs, two pixel maps, sizes, history, thresholds)
    mvo_labels: np.ndarray,
    shadow: np.ndarray,
    dist8: np.ndarray,
    blobs: BlobTable,
    sizes: SizeModel,
    legs_before: np.ndarray,
    *,
    cfg: BackgroundConfig,
) -> tuple[bool, np.ndarray, np.ndarray]:
    """Gives an MVO the pixels of its legs that it lost, in place. Returns whether any were,
    and per MVO (M,) float64 its legs score and the bottom row its legs reach (for the next
    frame's ``legs_before``). The score: its score in ``legs_before`` ((M, 2) per MVO, score
    and bottom row, from the last-frame MVOs it overlaps) times ``legs_score_decay``, plus 1
    if it is seen below the top border and ends where its legs stop (no regrowth needed),
    minus 1 if its legs are lost there; unchanged while it is cut by the top or its size is
    unknown.

    Dark gray trousers on gray pavement pass the shadow test, and thin lower legs fall apart
    into fragments that the opening removes or that fail the MVO tests: the MVO ends at the
    hips or the knees and its feet land there. The size line predicts where the feet of an
    MVO whose top edge is at row y are: the edge y_f with y_f - y = height at y_f. An MVO
    that ends more than ``legs_min_gap_frac`` of that height above where its legs should stop
    (``legs_stop_frac`` of the height above y_f) takes the changed pixels (``shadow`` or
    D_B > T_L, ``dist8`` the 8-bit D_B) of no other MVO that grow down from its torso
    (:func:`_grow_down`) in the corridor below it: rows from y + 0.3 (y_f - y) down to where
    the legs stop; columns of the torso (rows 0.15-0.3 of the height) widened by
    ``legs_width_frac`` of the height each side, for the stride. A cast shadow leaves that
    corridor, lies beyond y_f, or runs sideways, and stays a shadow. Blobs wider than 0.8 of
    the predicted height (groups) are left as they are.

    An MVO cut by the top border has no head there: y_f lies below its feet by what the
    border cuts, and its cast shadow grows into the corridor ('three' seed 0 cam1, precision
    0.810). One whose legs were mostly all there before it reached the border (a person
    walking out over the top; score above 0) gets legs grown only down to where they reached
    in the last frame, and only when its bottom rose above that (if above the size line's
    feet row) by more than ``legs_min_gap_frac`` of its height at once: legs it lost on the
    way out ('pillar' seed 0 cam1), not its shadow.
    """
    score = np.array(legs_before[:, 0], np.float64)
    reach_row = blobs.box_xywh[blobs.is_mvo, 1] + blobs.box_xywh[blobs.is_mvo, 3] - 0.5
    line = sizes.legs_line()
    if not cfg.regrow_legs or line is None:
        return False, score, reach_row
    t_low = _u8_floor(cfg.t_low)
    grown = False
    rows, cols = mvo_labels.shape
    box = blobs.box_xywh[blobs.is_mvo]
    for i, ((x, y, w, h), label, feet_edge) in enumerate(zip(
        box, blobs.mvo_label[blobs.is_mvo], feet_row(line, box[:, 1]).tolist(), strict=True
    )):
        height = feet_edge - y
        gap = feet_edge - (y + h)
        held = sizes.height_at(np.array([feet_edge]))  # NaN beyond a band's rows
        if height <= 0 or held is None or np.isnan(held[0]) or w > 0.8 * height:
            continue
        lost = gap >= (cfg.legs_stop_frac + cfg.legs_min_gap_frac) * height
        stop = min(rows, round(feet_edge - cfg.legs_stop_frac * height + 0.5))
        if y >= 0.5:  # below the top border (a box on it has its top edge at -0.5)
            score[i] = cfg.legs_score_decay * score[i] + (-1.0 if lost else 1.0)
        elif score[i] > 0:
            bottom, before = y + h - 0.5, legs_before[i, 1]
            vanished = bottom < before - cfg.legs_min_gap_frac * height and before < stop
            if vanished:  # held where they reached, not at the size line's feet row
                reach_row[i] = before
            lost = vanished
            stop = int(reach_row[i]) + 1
        if not lost:
            continue
        x0 = round(x + 0.5)  # box edges to pixel indices (pixel p covers p +- 0.5)
        start, torso_from = round(y + 0.3 * height + 0.5), round(y + 0.15 * height + 0.5)
        if y < 0.5 and start > round(y + h + 0.5):  # cut by the top and ending above its
            start = round(y + h + 0.5)  # torso rows (as a line of whole people puts them):
            torso_from = max(0, start - round(0.15 * height))  # its last rows instead
        torso = mvo_labels[torso_from:start, x0 : x0 + int(w)] == label
        torso_cols = np.flatnonzero(torso.any(axis=0))
        if len(torso_cols) == 0 or stop - start < 1:
            continue
        reach = round(cfg.legs_width_frac * height)
        c0 = max(0, x0 + int(torso_cols[0]) - reach)
        c1 = min(cols, x0 + int(torso_cols[-1]) + 1 + reach)
        r0 = start - 1  # one row of the MVO above the corridor: where the legs start
        window = mvo_labels[r0:stop, c0:c1]
        changed = shadow[r0:stop, c0:c1] | (dist8[r0:stop, c0:c1] > t_low)
        legs = _grow_down(window == label, changed & (window == 0))
        window[legs] = label
        if legs.any():
            reach_row[i] = max(reach_row[i], r0 + int(np.flatnonzero(legs.any(axis=1))[-1]))
        grown |= bool(legs.any())
    return grown, score, reach_row


def _grow_down(body: np.ndarray, shade: np.ndarray) -> np.ndarray:
    """The ``shade`` pixels (R, C) bool reached from ``body``'s first row going down through
    ``shade | body``, a pixel being reached from the three above it: legs, leaning up to 45
    degrees. A cast shadow running sideways from the feet is reached one column per row, not
    along its rows. Each row is a Python integer bit mask (bit c = column c), so a step is
    three shifts and two ands (a quarter of the time of boolean row arrays)."""
    rows, cols = shade.shape
    n_bytes = (cols + 7) // 8

    def bits(row: np.ndarray) -> int:
        return int.from_bytes(np.packbits(row, bitorder="little").tobytes(), "little")

    allowed = [bits(row) for row in shade | body]
    reached = np.zeros((rows, n_bytes), np.uint8)
    current = bits(body[0])
    for r in range(rows):
        if r:
            current = (current | current << 1 | current >> 1) & allowed[r]
            if not current:
                break
        reached[r] = np.frombuffer(current.to_bytes(n_bytes, "little"), np.uint8)
    return np.unpackbits(reached, axis=1, count=cols, bitorder="little").view(bool) & shade


def stacked_boxes(
    box_xywh: np.ndarray,
    x_overlap_frac: float,
    y_gap_frac: float,
    y_overlap_frac: float,
    max_aspect: float,
    cols: int | None = None,
) -> np.ndarray:
    """(K, K) bool: pairs of boxes stacked like the parts of one upright person.

    box_xywh: (K, 4) float64 boxes. A pair is stacked when their column ranges share at least
    ``x_overlap_frac`` of the narrower width, the vertical gap between them is at most
    ``y_gap_frac`` of the taller height, their row ranges share at most ``y_overlap_frac`` of
    the shorter height (people side by side are not stacked) and the union box is at most
    ``max_aspect`` times taller than wide (a far person above a near one's head is not),
    unless it reaches the left or right border of a frame ``cols`` wide (given): there the
    border cuts the width, and a person walking in or out is a sliver of any aspect
    (generated 'pillar' seed 2 cam1: torso and legs 6 px wide and 34 tall at the right border
    stayed two targets for 30 frames). Callers give ``cols`` only where a size model bounds
    the union's height instead (:func:`too_tall_unions`): without one, two people at the
    border, one walking out below one walking in, would pass ('doors' seed 3 cam1, frame 19).
    The diagonal is True. Shared with the tracker, which reunites fragment targets.
    """
    x0, y0, w, h = np.asarray(box_xywh, np.float64).reshape(-1, 4).T
    x1, y1 = x0 + w, y0 + h
    over_x = np.minimum(x1[:, None], x1) - np.maximum(x0[:, None], x0)
    over_y = np.minimum(y1[:, None], y1) - np.maximum(y0[:, None], y0)
    union_w = np.maximum(x1[:, None], x1) - np.minimum(x0[:, None], x0)
    union_h = np.maximum(y1[:, None], y1) - np.minimum(y0[:, None], y0)
    upright = union_h <= max_aspect * union_w
    if cols is not None:  # on the border with pixel-index (0, cols) or edge (-0.5) boxes
        cut = (x0 < 0.5) | (x1 > cols - 1.0)
        upright |= cut[:, None] | cut
    stacked = (
        (over_x >= x_overlap_frac * np.minimum(w[:, None], w))
        & (-over_y <= y_gap_frac * np.maximum(h[:, None], h))
        & (over_y <= y_overlap_frac * np.minimum(h[:, None], h))
        & upright
    )
    np.fill_diagonal(stacked, True)
    return stacked


def too_tall_unions(
    box_xywh: np.ndarray, sizes: SizeModel | None, max_frac: float
) -> np.ndarray | None:
    """(K, K) bool: pairs of boxes (K, 4) whose union is taller than ``max_frac`` times the
    person height ``sizes`` predicts at the union's bottom row: two people, one behind the
    other, not the parts of one. The diagonal is False. None without a prediction (no size
    model yet, or ``max_frac`` 0)."""
    if sizes is None or max_frac <= 0:
        return None
    top, bottom = box_xywh[:, 1], box_xywh[:, 1] + box_xywh[:, 3]
    union_bottom = np.maximum(bottom[:, None], bottom)
    person = sizes.height_at(union_bottom)
    if person is None:
        return None
    union_h = union_bottom - np.minimum(top[:, None], top)
    too_tall = (person > 0) & (union_h > max_frac * person)  # NaN (off a band's rows): False
    np.fill_diagonal(too_tall, False)
    return too_tall


def box_intersections(box_xywh: np.ndarray, other_xywh: np.ndarray | None = None) -> np.ndarray:
    """(K, M) float64: the area each box (K, 4) [x, y, w, h] shares with each of ``other_xywh``
    (M, 4) (default: the same boxes, K x K), 0 apart."""
    x0, y0, w, h = np.asarray(box_xywh, np.float64).reshape(-1, 4).T
    x1, y1, w1, h1 = (np.asarray(other_xywh, np.float64).reshape(-1, 4).T
                      if other_xywh is not None else (x0, y0, w, h))
    over_x = np.minimum(x0[:, None] + w[:, None], x1 + w1) - np.maximum(x0[:, None], x1)
    over_y = np.minimum(y0[:, None] + h[:, None], y1 + h1) - np.maximum(y0[:, None], y1)
    return np.clip(over_x, 0, None) * np.clip(over_y, 0, None)


def link_groups(linked: np.ndarray) -> tuple[int, np.ndarray]:
    """Connected components of a small symmetric (K, K) bool matrix: their count and each
    node's (K,) int64 component, numbered in the order of each component's first node (as
    scipy's ``connected_components``, whose sparse set-up costs 0.5 ms per call here, for
    graphs of a few blobs)."""
    k = len(linked)
    parent = list(range(k))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, j in zip(*np.nonzero(np.triu(linked | linked.T, 1)), strict=True):
        a, b = root(int(i)), root(int(j))
        parent[max(a, b)] = min(a, b)  # the root is the component's first node
    names: dict[int, int] = {}
    group = np.array([names.setdefault(root(i), len(names)) for i in range(k)], np.int64)
    return len(names), group


def _fragment_links(
    box_xywh: np.ndarray, cols: int, sizes: SizeModel, cfg: BackgroundConfig
) -> np.ndarray:
    """(K, K) bool: components that look like fragments of one person: stacked
    (:func:`stacked_boxes`) unless both are whole people (each at least ``group_whole_frac``
    of the person height ``sizes`` predicts at its bottom) taller together than one
    (:func:`too_tall_unions`), or one box inside the other (at least ``group_contained_frac``
    of the smaller box's area). box_xywh: (K, 4) float64; cols: the frame's width (at its
    side borders, with a size model, no aspect test)."""
    stacked = stacked_boxes(
        box_xywh,
        cfg.group_x_overlap_frac,
        cfg.group_y_gap_frac,
        cfg.group_y_overlap_frac,
        cfg.group_max_aspect,
        None if sizes.slope_intercept() is None else cols,
    )
    too_tall = too_tall_unions(box_xywh, sizes, cfg.group_max_height_frac)
    if too_tall is not None and too_tall.any():  # rare: only then the heights at each bottom
        person = sizes.height_at(box_xywh[:, 1] + box_xywh[:, 3])
        if person is not None:
            with np.errstate(invalid="ignore"):
                whole = box_xywh[:, 3] >= cfg.group_whole_frac * person  # NaN rows: False
            stacked &= ~(too_tall & whole[:, None] & whole)
    area = box_xywh[:, 2] * box_xywh[:, 3]
    inter = box_intersections(box_xywh)
    return stacked | (inter >= cfg.group_contained_frac * np.minimum(area[:, None], area))


def _group_fragments(
    comp_labels: np.ndarray,
    stats: np.ndarray,
    index: np.ndarray,
    sizes: SizeModel,
    cfg: BackgroundConfig,
) -> tuple[np.ndarray, np.ndarray]:
    """Join the connected components that are fragments of one person into one blob.

    comp_labels: (H,W) int32 components 0..K; stats: (K+1, 5) OpenCV component stats;
    index: (P,) int64 flat indices of the labelled (candidate) pixels; sizes: the camera's
    person heights, which bound a group's height.
    Returns the blob label image (H,W) int32 0..G and the blobs' stats (G+1, 5) in the same
    layout (box of the union, summed area). Blob labels follow the order of each blob's first
    component, so with no links the components are returned unchanged.
    """
    k = stats.shape[0] - 1
    if k < 2 or not cfg.group_fragments:
        return comp_labels, stats
    links = _fragment_links(stats[1:, :4].astype(np.float64), comp_labels.shape[1], sizes, cfg)
    n_groups, group = link_groups(links)
    if n_groups == k:
        return comp_labels, stats
    _, first = np.unique(group, return_index=True)
    rank = np.empty(n_groups, np.int32)
    rank[np.argsort(first, kind="stable")] = np.arange(1, n_groups + 1, dtype=np.int32)
    lut = np.concatenate([np.zeros(1, np.int32), rank[group]])
    x0, y0 = stats[1:, 0], stats[1:, 1]
    x1, y1 = x0 + stats[1:, 2], y0 + stats[1:, 3]
    out = np.zeros((n_groups + 1, 5), stats.dtype)
    out[0] = stats[0]
    g = lut[1:]
    big = np.iinfo(stats.dtype).max
    lo_x, lo_y = np.full(n_groups + 1, big), np.full(n_groups + 1, big)
    hi_x, hi_y = np.zeros(n_groups + 1, stats.dtype), np.zeros(n_groups + 1, stats.dtype)
    np.minimum.at(lo_x, g, x0)
    np.minimum.at(lo_y, g, y0)
    np.maximum.at(hi_x, g, x1)
    np.maximum.at(hi_y, g, y1)
    out[1:, cv2.CC_STAT_LEFT] = lo_x[1:]
    out[1:, cv2.CC_STAT_TOP] = lo_y[1:]
    out[1:, cv2.CC_STAT_WIDTH] = hi_x[1:] - lo_x[1:]
    out[1:, cv2.CC_STAT_HEIGHT] = hi_y[1:] - lo_y[1:]
    out[1:, cv2.CC_STAT_AREA] = np.bincount(g, weights=stats[1:, 4], minlength=n_groups + 1)[1:]
    labels = np.zeros_like(comp_labels)
    labels.ravel()[index] = lut[comp_labels.ravel()[index]]
    return labels, out


def _candidates(dist8: np.ndarray, shadow: np.ndarray, cfg: BackgroundConfig) -> np.ndarray:
    """D_B > T_L, opened with a square kernel, shadow pixels removed: (H,W) bool."""
    raw = dist8 > _u8_floor(cfg.t_low)
    if cfg.open_kernel_px > 1:
        kernel = np.ones((cfg.open_kernel_px, cfg.open_kernel_px), np.uint8)
        raw = cv2.morphologyEx(raw.view(np.uint8), cv2.MORPH_OPEN, kernel).view(bool)
    return raw & ~shadow


_Shared = tuple[tuple[np.ndarray, np.ndarray] | None, ...]


def _fifo_median(
    samples: Sequence[np.ndarray], shared: _Shared, spacing: int
) -> tuple[np.ndarray, _Shared]:
    """Lower median of the FIFO samples (newest first, n of them) and the new ``shared``.

    With k = (n-1)//2 and lo, hi ranks k-1 and k of n-1 samples, rank k of those and x is
    clamp(x, lo, hi). The samples m steps ago without their oldest are this step's samples
    without the newest: a pair stored then gives this median from the newest sample alone.
    """
    n = len(samples)
    if n < 3:
        return lower_median(samples), ()
    slots = shared if len(shared) == spacing else (None,) * spacing
    stored = slots[0]
    if stored is not None:
        return clamp(samples[0], *stored), (*slots[1:], None)
    k = (n - 1) // 2
    lo, hi = order_statistics(samples[:-1], (k - 1, k))
    median = clamp(samples[-1], lo, hi)
    return median, (*slots[1:], (_readonly(lo), _readonly(hi)))


def _update(
    state: BackgroundState, frame: np.ndarray, keep_out: np.ndarray, cfg: BackgroundConfig
) -> tuple[tuple[np.ndarray, ...], _Model, _Shared]:
    """Push the frame with ``keep_out`` pixels replaced by B; the new FIFO, B and shared
    ranks."""
    pushed = frame.copy()
    cv2.copyTo(state.model.bgr, keep_out.view(np.uint8), pushed)
    fifo = (*state.fifo[1:], _readonly(pushed))
    newest = len(fifo) - 1
    samples = [fifo[newest - i * cfg.fifo_spacing_frames] for i in range(cfg.fifo_n)]
    median, shared = _fifo_median(samples, state.shared, cfg.fifo_spacing_frames)
    return fifo, _model(median, state.modality, cfg), shared


def _motion(
    state: BackgroundState, flow_gray: np.ndarray, factor: int, k: int, cfg: BackgroundConfig
) -> _Motion:
    """Flow and changed map of the current frame against the oldest kept one, per frame of the
    gap; none when there are no blobs or no previous frame."""
    if k == 0 or not state.recent_v:
        return _Motion(None, None, factor)
    prev = state.recent_v[0]
    flow = _flow(prev, flow_gray, factor) / np.float32(len(state.recent_v))
    changed = cv2.absdiff(prev, flow_gray) > _u8_floor(cfg.change_min_diff)
    return _Motion(flow, changed, factor)


def _learn_sizes(sizes: SizeModel, blobs: BlobTable, shape: tuple[int, ...],
                 cfg: BackgroundConfig, frame_index: int,
                 merged: np.ndarray | None = None) -> SizeModel:
    """The model with this frame's person-shaped MVOs added, refitted every
    ``size_refit_frames`` frames; none of the blobs ``merged`` (K,) bool marks
    (:func:`_merged_blobs`): two people one behind the other are one blob shaped like a
    person and taller than one."""
    if cfg.size_area_frac <= 0:
        return sizes
    # Moving, person-shaped blobs below T_area count too: where people are smaller than T_area
    # none would ever become an MVO to learn from.
    person = blobs.strong_ok & blobs.edge_ok & blobs.moving_ok & (
        blobs.area_px >= cfg.size_min_area_px)
    take = blobs.is_mvo | person
    if merged is not None:
        take &= ~merged
    box = blobs.box_xywh[take]
    inside = _inside(box, shape)
    aspect = box[:, 3] / np.maximum(box[:, 2], 1.0)
    keep = inside & (aspect >= cfg.size_min_aspect) & (aspect <= cfg.size_max_aspect)
    new = np.c_[box[keep, 1] + box[keep, 3], box[keep, 3]]
    samples = _readonly(np.concatenate([sizes.samples, new])[-cfg.size_samples :])
    fit = None if frame_index % cfg.size_refit_frames else _fit_sizes(samples, shape[0], cfg)
    # A line is not given up when the newest samples crowd into a few rows (or a refit
    # fails): it still holds where people walked before.
    if fit is None or (sizes.line is not None and fit.line is None):
        return replace(sizes, samples=samples)
    return fit


_WHOLE_DRAWS = 300  # candidate lines of _whole_line


def _fit_sizes(samples: np.ndarray, frame_height: int, cfg: BackgroundConfig) -> SizeModel | None:
    """Robust line height = slope * row + intercept: least squares, then again on the samples
    within 2.5 robust sigmas (MAD) of it, twice. When the rows spread over less than
    ``size_min_row_spread_frac`` of the frame, a band instead: the median height on the
    sampled rows (5-95 %) widened by ``size_band_heights`` times that height each way.
    None with fewer than ``size_min_samples`` samples, a clustered set and no band
    (``size_band_heights`` 0), or a line that does not predict positive heights over the
    sampled rows. The model's samples are ``samples``."""
    if len(samples) < cfg.size_min_samples:
        return None
    rows, heights = samples[:, 0], samples[:, 1]
    lo, hi = np.percentile(rows, [5, 95])
    if hi - lo < cfg.size_min_row_spread_frac * frame_height:
        if cfg.size_band_heights <= 0:
            return None
        median = float(np.median(heights))
        pad = cfg.size_band_heights * median
        return SizeModel(samples, band=(median, float(lo - pad), float(hi + pad)))
    keep = np.ones(len(rows), bool)
    slope = intercept = 0.0
    for _ in range(3):
        slope, intercept = np.polyfit(rows[keep], heights[keep], 1)
        resid = heights - (slope * rows + intercept)
        mad = float(np.median(np.abs(resid[keep] - np.median(resid[keep]))))
        keep = np.abs(resid) <= 2.5 * 1.4826 * max(mad, 0.5)
        if keep.sum() < cfg.size_min_samples // 2:
            return None
    if min(slope * lo + intercept, slope * hi + intercept) <= 0:
        return None
    whole = _whole_line(rows, heights, frame_height, cfg)
    if whole is not None and whole[0] > slope:  # lost legs only steepen the fit: not them
        whole = None
    return SizeModel(samples, (float(slope), float(intercept)), whole=whole)


def _whole_line(rows: np.ndarray, heights: np.ndarray, frame_height: int,
                cfg: BackgroundConfig) -> tuple[float, float] | None:
    """The line (slope, intercept) through the most samples within ``size_whole_tol`` of
    their predicted height, then refitted to those twice (RANSAC with a relative tolerance):
    statures vary by +-8 %, legs lost at the hips take a third to a half. Candidates are the
    lines through ``_WHOLE_DRAWS`` pairs of samples at least a tenth of the frame apart in
    rows, drawn with a fixed seed (the same samples give the same line), that predict
    positive heights on every sample's row with a slope in (0, 1). None without one, or
    with fewer than half of ``size_min_samples`` near it. :func:`_fit_sizes` keeps it only
    when it is no steeper than the least-squares line: short far samples steepen that one,
    and a steeper consensus is of something else (people entering at the top, their heads
    cut at row 1, give height = bottom row: 'pair' s3 cam1 frame 100, slope 0.96)."""
    tol = cfg.size_whole_tol
    i, j = np.random.default_rng(0).integers(0, len(rows), (2, _WHOLE_DRAWS))
    apart = np.abs(rows[i] - rows[j]) >= 0.1 * frame_height
    i, j = i[apart], j[apart]
    slope = (heights[i] - heights[j]) / (rows[i] - rows[j])
    intercept = heights[i] - slope * rows[i]
    pred = slope[:, None] * rows[None, :] + intercept[:, None]  # (draws, samples)
    ok = (slope > 0) & (slope < 1) & (pred.min(axis=1, initial=np.inf) > 0)
    if not ok.any():
        return None
    near = np.abs(heights[None, :] - pred[ok]) <= tol * pred[ok]
    best = near[np.argmax(near.sum(axis=1))]
    for _ in range(2):
        if best.sum() < cfg.size_min_samples // 2:
            return None
        fit = np.polyfit(rows[best], heights[best], 1)
        pred_best = np.maximum(fit[0] * rows + fit[1], 1.0)
        best = np.abs(heights - pred_best) <= tol * pred_best
    if not 0.0 < fit[0] < 1.0:
        return None
    return float(fit[0]), float(fit[1])


def background_step(
    state: BackgroundState, frame: np.ndarray, cfg: BackgroundConfig
) -> tuple[BackgroundState, BackgroundResult]:
    """Process one frame (BGR (H,W,3) or gray (H,W) uint8, same size as training)."""
    frame = _as_frame(frame, state.modality)
    if frame.shape != state.model.bgr.shape:
        raise ValueError(
            f"background_step: frame {frame.shape} but background {state.model.bgr.shape}"
        )
    if len(state.fifo) != _fifo_len(cfg):
        raise ValueError(
            f"background_step: FIFO holds {len(state.fifo)} frames but the config "
            f"needs {_fifo_len(cfg)}: train with the same BackgroundConfig"
        )
    planes = _hsv_planes(frame, state.modality)
    dist8, shadow = _distance_and_shadow(planes, state.model, cfg)
    candidate = _candidates(dist8, shadow, cfg)
    _, comp_labels, comp_stats, _ = cv2.connectedComponentsWithStatsWithAlgorithm(
        candidate.view(np.uint8), 8, cv2.CV_32S, cv2.CCL_GRANA
    )
    index = np.flatnonzero(candidate)  # the few candidate pixels: cheaper than full gathers
    blob_labels, stats = _group_fragments(comp_labels, comp_stats, index, state.sizes, cfg)
    assert planes[2] is not None
    flow_gray = _flow_gray(planes[2], cfg)
    k = stats.shape[0] - 1
    motion = _motion(state, flow_gray, frame.shape[1] // flow_gray.shape[1], k, cfg)
    pixels = _blob_pixels(index, blob_labels)
    max8 = np.zeros(k + 1, np.uint8)
    np.maximum.at(max8, pixels.label, dist8.ravel()[pixels.index])
    overlaps = _prev_overlaps(pixels, state.mvo_prev)
    evidence = _BlobEvidence(
        max8[1:],
        *_blob_motion(pixels, stats[1:, cv2.CC_STAT_AREA], frame.shape[1], motion),
        *_blob_edges(candidate, blob_labels, (planes[2], state.model.v), k, cfg),
        overlaps,
        _hold_ages(overlaps, state.mvo_ages, k),
    )
    min_area = min_area_at(candidate.shape, cfg)
    area_sizes = state.sizes  # or, until it has a model, the training frames'
    if state.sizes.slope_intercept() is None and state.prior_sizes is not None:
        area_sizes = state.prior_sizes
    thresholds = _area_thresholds(stats, area_sizes, min_area, cfg)
    blobs, age = _blob_table(stats, evidence, cfg, min_area, thresholds, candidate.shape)
    mvo_labels, mvo_index = _mvo_labels(pixels, blobs, candidate.shape)
    mvo = mvo_labels > 0
    legs_before = _legs_before(overlaps, state.mvo_legs, k)[blobs.is_mvo]
    merged = (_merged_blobs(overlaps, state.mvo_merged, blobs, state.sizes, cfg.size_whole_tol)
              if cfg.size_skip_merged else np.zeros(k, bool))
    grown, legs, reach = _regrow_legs(mvo_labels, shadow, dist8, blobs, state.sizes, legs_before,
                                      cfg=cfg)
    if grown:
        mvo = mvo_labels > 0
        shadow = shadow & ~mvo
        mvo_index = np.flatnonzero(mvo)
    fg_shadow = _split_shadows(shadow, mvo, mvo_index, cfg.fg_shadow_gap_px)
    mover = _blob_mask(pixels, blobs.border_mover, candidate.shape)
    keep_out = mvo | fg_shadow | mover if cfg.keep_border_movers else mvo | fg_shadow
    fifo, model, shared = _update(state, frame, keep_out, cfg)
    result = BackgroundResult(
        frame_index=state.frame_index,
        background_bgr=state.model.bgr,
        distance_u8=dist8,
        shadow=shadow,
        candidate=candidate,
        blob_labels=blob_labels,
        mvo_labels=mvo_labels,
        ghost_mask=candidate & ~mvo & ~mover,
        border_mover_mask=mover,
        fg_shadow=fg_shadow,
        ghost_shadow=shadow & ~fg_shadow,
        blobs=blobs,
        sizes=state.sizes,
    )
    new_state = BackgroundState(
        modality=state.modality,
        fifo=fifo,
        model=model,
        recent_v=(*state.recent_v, flow_gray)[-cfg.flow_gap_frames :],
        frame_index=state.frame_index + 1,
        mvo_prev=_readonly(mvo_labels),
        mvo_ages=_readonly(age[blobs.is_mvo]),  # in MVO label order
        mvo_legs=_readonly(np.c_[legs, reach]),
        mvo_merged=_readonly(merged[blobs.is_mvo]),
        shared=shared,
        sizes=_learn_sizes(state.sizes, blobs, candidate.shape, cfg, state.frame_index, merged),
        prior_sizes=state.prior_sizes,
    )
    return new_state, result
