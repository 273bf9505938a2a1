"""Exact per-pixel median of a few uint8 images with a pruned selection network.

``np.median`` over a stack of 8 frames at 768×576×3 costs about 100 ms: it copies the stack and
runs a per-pixel introselect. A sorting network needs only element-wise ``min``/``max`` of whole
images, which run with SIMD at memory speed (about 0.14 ms per 1.3 MB image here). Batcher's
odd-even merge sort for n inputs, pruned backwards to the one comparator output the median
needs, keeps 27 of the 38 min/max operations for n = 8. Run in cache-sized chunks this is about
2.5 ms, 40× faster than ``np.median``, and *exact*.

Median of an even count: the **lower median**, element ``(n - 1) // 2`` of the sorted samples
(``np.quantile(..., 0.5, method="lower")``). It is always one of the observed values, never a
blend of two; for odd n it equals ``np.median``.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache

import cv2
import numpy as np

__all__ = ["lower_median", "median_network"]

# (low wire, high wire, keep min, keep max): after the comparator the low wire holds the min
# (if kept) and the high wire the max (if kept).
Comparator = tuple[int, int, bool, bool]

# Work in chunks of this many elements so that the n inputs and the temporaries of one chunk stay
# in the CPU's L2 cache: 2.5 ms instead of 4.3 ms (whole images) for 8 frames at 768×576×3.
# OpenCV's min/max (SIMD, less call overhead than numpy's ufuncs) on 65536-element chunks:
# 2.3 ms against 2.7-3.1 ms for numpy on 32768 (8 frames at 768×576×3, one thread).
_CHUNK_ELEMENTS = 65536


def _batcher_pairs(n_pow2: int) -> list[tuple[int, int]]:
    """Comparators of Batcher's odd-even merge sort for a power-of-two count of wires."""
    pairs: list[tuple[int, int]] = []
    p = 1
    while p < n_pow2:
        k = p
        while k >= 1:
            for j in range(k % p, n_pow2 - k, 2 * k):
                for i in range(min(k, n_pow2 - j - k)):
                    if (i + j) // (2 * p) == (i + j + k) // (2 * p):
                        pairs.append((i + j, i + j + k))
            k //= 2
        p *= 2
    return pairs


@lru_cache(maxsize=64)
def median_network(n: int) -> tuple[tuple[Comparator, ...], int]:
    """The pruned comparators for the lower median of n buffers, and the buffer that ends with it.

    Wires n..(next power of two - 1) are padding that hold +infinity: a comparator with one
    infinite wire is a relabelling (the finite value goes to the low wire), so it is folded into
    a wire permutation instead of being computed. Then comparators that cannot influence the
    median wire are dropped, and of the kept ones only the needed half (min or max) is computed.
    """
    if n < 1:
        raise ValueError(f"median of n = {n} images: n must be at least 1")
    size = 1 << (n - 1).bit_length()
    # slot[w] = physical buffer index that logical wire w holds, or -1 for +infinity.
    slot = [w if w < n else -1 for w in range(size)]
    raw: list[tuple[int, int]] = []  # comparators on physical buffers (min into first)
    for a, b in _batcher_pairs(size):
        sa, sb = slot[a], slot[b]
        if sa < 0 and sb >= 0:
            slot[a], slot[b] = sb, -1  # min(inf, x) = x goes low, inf goes high
        elif sa >= 0 and sb >= 0:
            raw.append((sa, sb))
    target = {slot[(n - 1) // 2]}
    kept: list[Comparator] = []
    for lo, hi in reversed(raw):
        keep_min, keep_max = lo in target, hi in target
        if keep_min or keep_max:
            kept.append((lo, hi, keep_min, keep_max))
            target |= {lo, hi}
    return tuple(reversed(kept)), slot[(n - 1) // 2]


def lower_median(images: Sequence[np.ndarray]) -> np.ndarray:
    """Per-pixel lower median of n same-shaped uint8 images (any shape, e.g. (H,W,3) or (H,W)).

    Returns a new array of the same shape and dtype: element ``(n - 1) // 2`` of each pixel's
    sorted samples. Exact; the inputs are not modified.
    """
    if len(images) == 0:
        raise ValueError("lower_median: no images")
    first = images[0]
    for i, img in enumerate(images):
        if img.shape != first.shape or img.dtype != first.dtype:
            raise ValueError(
                f"lower_median: image {i} is {img.shape} {img.dtype}, "
                f"image 0 is {first.shape} {first.dtype}"
            )
    if len(images) == 1:
        return np.array(first, copy=True)
    network, out_wire = median_network(len(images))
    flat = [np.ascontiguousarray(img).reshape(-1) for img in images]
    out = np.empty(first.size, dtype=first.dtype)
    for start in range(0, first.size, _CHUNK_ELEMENTS):
        wires = [f[start : start + _CHUNK_ELEMENTS] for f in flat]  # views; never written
        length = wires[0].shape[0]
        for lo, hi, keep_min, keep_max in network:
            a, b = wires[lo], wires[hi]
            if keep_min:
                wires[lo] = cv2.min(a, b)  # new (length, 1) arrays
            if keep_max:
                wires[hi] = cv2.max(a, b)
        out[start : start + length] = wires[out_wire].reshape(-1)
    return out.reshape(first.shape)
