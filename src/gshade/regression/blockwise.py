"""The reductions of :func:`gshade.regression.comparison.compare`, over blocks of pixels.

Two large images are compared a block of pixels (in row-major order) at a time, in their
stored types (float16, float32), so that no whole-image float64 copy is made unless the
difference images are asked for.  The figures are exactly those of the whole-image numpy
expressions they replace: maxima, counts and first positions do not depend on the blocks,
and :class:`ExactSum` adds the values in numpy's own (pairwise) order, so that the means,
RMSEs and PSNRs agree to the last bit.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

__all__ = ["BLOCK", "Blocks", "ExactSum", "Reduction", "reduce_blocks", "spans"]

#: Pixels per block: a few of them in float64 per channel stay in the processor's caches.
BLOCK = 1 << 15

#: numpy's pairwise summation: runs of up to 128 values are added with 8 accumulators,
#: longer ones split in two halves (the first a multiple of 8 long).
_PAIRWISE_RUN = 128

_LARGEST = float(np.finfo(np.float64).max)


def _split(n: int) -> int:
    half = n // 2
    return half - half % 8


class ExactSum:
    """``np.add.reduce`` of ``n`` float64 values given piece by piece, bit for bit.

    numpy adds a contiguous array pairwise: the sum of ``n > 128`` values is the sum of its
    first :func:`_split` ``(n)`` values plus that of the rest.  Each subtree that lies
    within the values given so far is summed by numpy itself; only a run of at most 128
    values that straddles two pieces waits (copied) for the next one.
    """

    def __init__(self, n: int) -> None:
        self.n = n
        self.total = 0.0
        # the subtrees being summed, innermost last: [start, length, sum of its first half]
        self._pending: list[list] = [[0, n, None]] if n else []
        self._tail: NDArray[np.float64] = np.empty(0)
        self._start = 0  # the index of _tail[0]

    def add(self, values: NDArray[np.float64]) -> None:
        """Add the next values (a contiguous float64 array, read now and not kept)."""
        buf = np.concatenate((self._tail, values.ravel())) if self._tail.size else values.ravel()
        start, end, pending = self._start, self._start + buf.size, self._pending
        if end > self.n:
            raise ValueError(f"ExactSum: expected {self.n} values, got {end}")
        while pending:
            s, length, _ = pending[-1]
            if s + length > end:
                if length <= _PAIRWISE_RUN:
                    break  # a run that the next piece completes
                pending.append([s, _split(length), None])
                continue
            value = float(np.add.reduce(buf[s - start : s + length - start]))
            pending.pop()
            while pending:  # hand the sum to the subtrees that contain it
                parent = pending[-1]
                if parent[2] is None:
                    parent[2] = value
                    half = _split(parent[1])
                    pending.append([parent[0] + half, parent[1] - half, None])
                    break
                value = parent[2] + value
                pending.pop()
            else:
                self.total = 0.0 + value
        first = pending[-1][0] if pending else end
        self._tail = buf[first - start :].copy()
        self._start = first

    def result(self) -> float:
        """The sum (of all ``n`` values: they must all have been added)."""
        if self._pending:
            raise ValueError(f"ExactSum: expected {self.n} values, got {self._start}")
        return self.total


@dataclass
class Reduction:
    """Running figures of one channel's or one channel group's pixel difference (the
    largest absolute difference over the group's channels, infinite where non-finite)."""

    members: list[int]
    n: int
    max_error: float = -1.0
    max_index: int = -1  # the first pixel (row-major) with max_error
    nonfinite: int = 0  # pixels whose difference is not finite (NaN, infinity, overflow)
    nonfinite_test: int = 0
    nonfinite_reference: int = 0
    reference_min: float = float("inf")  # over the finite reference values
    reference_max: float = float("-inf")
    sum: ExactSum = field(init=False)
    sum_of_squares: ExactSum = field(init=False)

    def __post_init__(self) -> None:
        self.sum, self.sum_of_squares = ExactSum(self.n), ExactSum(self.n)

    def add_maximum(self, value: float, index: int) -> None:
        """Take a block's largest value (not NaN) and its first pixel."""
        if value > self.max_error:  # the first largest: an equal one later does not count
            self.max_error, self.max_index = value, index

    def add_sums(self, magnitude: NDArray[np.float64], square: NDArray[np.float64]) -> None:
        if self.nonfinite == 0:  # otherwise the mean and RMSE are infinite
            self.sum.add(magnitude)
            np.multiply(magnitude, magnitude, out=square)
            self.sum_of_squares.add(square)

    def add_reference(self, values: NDArray) -> None:
        lo, hi = values.min(), values.max()
        if not (np.isfinite(lo) and np.isfinite(hi)):
            finite = values[np.isfinite(values)]
            if not finite.size:
                return
            lo, hi = finite.min(), finite.max()
        self.reference_min = min(self.reference_min, float(lo))
        self.reference_max = max(self.reference_max, float(hi))


@dataclass
class Blocks:
    """What :func:`reduce_blocks` found."""

    channels: list[Reduction]
    groups: list[Reduction]
    values: ExactSum  # of every value's |difference|, pixel after pixel
    values_of_squares: ExactSum
    #: (pixels, channels): test - reference, NaN where either is not finite (with ``keep``)
    difference: NDArray[np.float64] | None
    pixel_difference: NDArray[np.float64] | None  # (pixels,): the last group's
    failing: int = 0
    warning: int = 0
    hardfail: bool = False
    values_finite: bool = True  # every value of both images finite
    peak: float | None = None  # the largest magnitude of a pair of finite values


def spans(n: int, block: int) -> Iterator[tuple[int, int]]:
    """The blocks (start, stop) of ``n`` pixels: the subtrees of numpy's pairwise sum of
    ``n`` values that are at most ``block`` long (so that each block's sum is one numpy
    sum), cut further into ``block``-long pieces if ``block`` is under 128."""
    pending = [(0, n)] if n else []
    while pending:
        start, length = pending.pop()
        if length > block and length > _PAIRWISE_RUN:
            half = _split(length)
            pending += [(start + half, length - half), (start, half)]
        else:
            for p0 in range(start, start + length, block):
                yield p0, min(p0 + block, start + length)


@dataclass
class _Scratch:
    """The float64 arrays of one block, reused from block to block."""

    test: NDArray[np.float64]  # (block,): one channel's test values
    reference: NDArray[np.float64]  # (channels, block)
    magnitude: NDArray[np.float64]  # (channels, block): |test - reference|, inf if non-finite
    interleaved: NDArray[np.float64]  # (block, channels)
    worst: NDArray[np.float64]
    square: NDArray[np.float64]
    largest: NDArray[np.float64]

    @classmethod
    def of(cls, channels: int, block: int) -> _Scratch:
        return cls(
            *(np.empty(block), np.empty((channels, block)), np.empty((channels, block))),
            *(np.empty((block, channels)), np.empty(block), np.empty(block), np.empty(block)),
        )


def reduce_blocks(
    test: list[NDArray],
    reference: list[NDArray],
    groups: list[list[int]],
    thresholds: tuple[float, float, float],
    *,
    keep: bool = False,
    block: int | None = None,
) -> Blocks:
    """Reduce the differences of ``test`` and ``reference`` (the compared channels: arrays
    of one shape, C-contiguous, of float16, float32 or float64) block by block.

    ``groups`` are lists of channel indices; the last one is the overall group (every
    channel), whose pixel difference is counted against ``thresholds`` (fail, warn,
    hardfail).  With ``keep``, the signed differences and the pixel difference are kept.
    ``block``: pixels per block, :data:`BLOCK` by default."""
    block = block or BLOCK
    count, n = len(test), int(np.prod(test[0].shape))
    flat_test = [a.reshape(-1) for a in test]
    flat_reference = [b.reshape(-1) for b in reference]
    out = Blocks(
        channels=[Reduction([k], n) for k in range(count)],
        groups=[Reduction(g, n) for g in groups],
        values=ExactSum(n * count),
        values_of_squares=ExactSum(n * count),
        difference=np.empty((n, count)) if keep else None,
        pixel_difference=np.empty(n) if keep else None,
    )
    scratch = _Scratch.of(count, min(block, max(n, 1)))
    with np.errstate(over="ignore", invalid="ignore"):  # an overflowing difference: inf
        _reduce(out, flat_test, flat_reference, thresholds, spans(n, block), scratch)
    return out


def _reduce(
    out: Blocks,
    flat_test: list[NDArray],
    flat_reference: list[NDArray],
    thresholds: tuple[float, float, float],
    blocks: Iterator[tuple[int, int]],
    scratch: _Scratch,
) -> None:
    count = len(flat_test)
    fail, warn, hardfail = thresholds
    for p0, p1 in blocks:
        m = p1 - p0
        bad: list[tuple[NDArray[np.bool_], NDArray[np.bool_]] | None] = [None] * count
        for k in range(count):
            bad[k] = _add_channel(
                out, k, flat_test[k][p0:p1], flat_reference[k][p0:p1], scratch, p0
            )
        mags = scratch.magnitude[:, :m]
        if out.values_finite:  # idiff's figures: over every value, pixel after pixel
            values = scratch.interleaved[:m]
            np.copyto(values, mags.T)
            out.values.add(values)
            np.multiply(values, values, out=values)
            out.values_of_squares.add(values)
        for red in out.groups:
            _add_group(red, scratch, bad, p0, m)
        w = scratch.worst[:m]  # the last group's: every channel's
        out.failing += int(np.count_nonzero(w > fail))
        out.warning += int(np.count_nonzero(w > warn))
        out.hardfail = out.hardfail or bool(np.any(w > hardfail))
        if out.pixel_difference is not None:
            out.pixel_difference[p0:p1] = w


def _add_channel(
    out: Blocks, k: int, ta: NDArray, tb: NDArray, scratch: _Scratch, p0: int
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]] | None:
    """One block of channel ``k``: its magnitudes (left in ``scratch``), its figures and
    the values' peak; where a value is not finite, where (test, reference)."""
    m, red = ta.size, out.channels[k]
    a, b, mag = scratch.test[:m], scratch.reference[k, :m], scratch.magnitude[k, :m]
    np.copyto(a, ta)  # the exact values, as float64
    np.copyto(b, tb)
    np.subtract(a, b, out=mag)
    if out.difference is not None:
        out.difference[p0 : p0 + m, k] = mag
    np.abs(mag, out=mag)
    i = int(np.argmax(mag))
    found = None
    if mag[i] <= _LARGEST:  # every difference finite: so is every value
        top = max(float(a.max()), -float(a.min()))
        lo, hi = float(b.min()), float(b.max())
        red.reference_min = min(red.reference_min, lo)
        red.reference_max = max(red.reference_max, hi)
        top = max(top, hi, -lo)
        out.peak = top if out.peak is None else max(out.peak, top)
    else:  # NaN (argmax finds the first) or infinity
        fa, fb = np.isfinite(a), np.isfinite(b)
        found = (~fa, ~fb)
        pair = fa & fb
        mag[~pair] = np.inf  # never a match
        if out.difference is not None:
            out.difference[p0 : p0 + m, k][~pair] = np.nan
        red.nonfinite += int(np.count_nonzero(np.isinf(mag)))
        red.nonfinite_test += int(m - np.count_nonzero(fa))
        red.nonfinite_reference += int(m - np.count_nonzero(fb))
        i = int(np.argmax(mag))
        out.values_finite = out.values_finite and bool(pair.all())
        if pair.any():
            top = max(float(np.abs(a[pair]).max()), float(np.abs(b[pair]).max()))
            out.peak = top if out.peak is None else max(out.peak, top)
        red.add_reference(b)
    red.add_maximum(float(mag[i]), p0 + i)
    red.add_sums(mag, scratch.square[:m])
    return found


def _add_group(
    red: Reduction,
    scratch: _Scratch,
    bad: list[tuple[NDArray[np.bool_], NDArray[np.bool_]] | None],
    p0: int,
    m: int,
) -> None:
    """One block of a group: its pixel difference (left in ``scratch.worst``), and the
    largest reference value of each pixel over its channels."""
    members = red.members
    w, r = scratch.worst[:m], scratch.largest[:m]
    if members == list(range(members[0], members[-1] + 1)):
        rows: slice | list[int] = slice(members[0], members[-1] + 1)
    else:
        rows = members
    np.max(scratch.magnitude[rows, :m], axis=0, out=w)
    np.max(scratch.reference[rows, :m], axis=0, out=r)  # NaN wins, as in ndarray.max
    i = int(np.argmax(w))
    red.add_maximum(float(w[i]), p0 + i)
    if w[i] == np.inf:
        red.nonfinite += int(np.count_nonzero(np.isinf(w)))
        for side in (0, 1):
            masks = [found[side] for found in (bad[k] for k in members) if found is not None]
            if masks:
                count = int(np.count_nonzero(np.any(masks, axis=0)))
                if side == 0:
                    red.nonfinite_test += count
                else:
                    red.nonfinite_reference += count
    red.add_sums(w, scratch.square[:m])
    red.add_reference(r)
