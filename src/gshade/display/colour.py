"""How shape-function values become colours: anti-aliased stripes and colour maps.

Pure functions, numpy in -> RGB (linear, float) out.

Stripes (Kiciak's BSTools style): with s = f / T + phase, a point is on a dark stripe where
fract(s) < duty.  Anti-aliasing box-filters that indicator over the pixel footprint w (in
units of s, e.g. w = |grad_S f| * pixel size / T): with Q(x) = floor(x) duty + min(fract(x), duty)
the dark coverage is (Q(s + w/2) - Q(s - w/2)) / w, which fades to ``duty`` (grey) where the
stripes are denser than the pixels instead of aliasing into moiré.

Colour maps come from matplotlib: a perceptually uniform map (viridis) for unsigned values,
a diverging map symmetric about 0 (coolwarm) for signed ones such as curvature.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import GshadeError, show
from ..runtime.backend import NUMPY_NAN, ArrayOps
from .colour_maps import validate_colormap

__all__ = [
    "ColourMapped",
    "Legend",
    "auto_range",
    "colour_map",
    "combine",
    "edge_offset",
    "stripe_coverage",
    "stripe_period",
    "stripes",
    "trapezoid_cdf",
    "validate_colormap",
    "validate_range",
]

DARK = (0.04, 0.04, 0.05)
LIGHT = (0.92, 0.92, 0.90)
#: colour of points where the shape function is undefined
UNDEFINED = (0.25, 0.1, 0.3)


def _primitive(x: Any, duty: float, ops: ArrayOps) -> Any:
    """Q(x) = floor(x) duty + min(fract(x), duty): the integral of the stripe indicator."""
    fl = ops.floor(x)
    return fl * duty + ops.minimum(x - fl, duty)


def _periodic_part(x: Any, duty: float, ops: ArrayOps) -> Any:
    """B(x): the second primitive Q2(x) = int_0^x Q less its quadratic and linear trend,
    Q2(x) = duty x^2 / 2 + c x + B(x) with c = duty (1 - duty) / 2.  B has period 1 and
    |B| <= 1/32, so it is evaluated at fract(x): no large terms to cancel."""
    tau = x - ops.floor(x)
    c = 0.5 * duty * (1.0 - duty)
    dark = 0.5 * (1.0 - duty) * tau * tau
    light = 0.5 * (1.0 - duty) * duty * duty + duty * (tau - duty) * (1.0 - 0.5 * (tau + duty))
    return ops.select(tau <= duty, dark, light) - c * tau


def _two_sum(p: Any, q: Any) -> tuple[Any, Any]:
    """p + q as the rounded sum and its exact rounding error (Knuth's TwoSum: no FMA)."""
    total = p + q
    q_part = total - p
    return total, (p - (total - q_part)) + (q - q_part)


def _nearest_edge(t: Any, duty: float, ops: ArrayOps) -> tuple[Any, Any]:
    """For t in [0, 1]: the offset ``edge - t`` of the nearest stripe edge (a fall from dark
    to light at ``duty``, or a rise at 0 or 1) and whether that edge is a fall."""
    rise = ops.select(t < 0.5 * (1.0 + duty), 0.0, 1.0)
    at_fall = ops.abs(t - duty) < ops.abs(t - rise)
    # (select of two Python numbers gives Dr.Jit's single-precision Float: keep duty out)
    return ops.select(at_fall, duty - t, rise - t), at_fall


#: Stripe coordinates s known only to single precision (a renderer's f from float32 data,
#: its slopes from differences of such data): within this many units in the last place of
#: a float32 s of an edge, a pixel whose footprint is narrower still lies on the edge.
SETTLE_ULPS = 64


def edge_offset(s: Any, duty: float, ops: ArrayOps = NUMPY_NAN) -> Any:
    """The offset (in periods) from stripe coordinates s to their nearest stripe edge (a
    rise at a whole number, a fall at a whole number + ``duty``): edge - s.

    Examples
    --------
    >>> import numpy as np
    >>> edge_offset(np.array([10.05, 10.45, 10.8]), 0.5).round(6).tolist()
    [-0.05, 0.05, 0.2]
    """
    return _nearest_edge(s - ops.floor(s), duty, ops)[0]


def settled_on_edges(
    s: Any, a: Any, b: Any, duty: float, ops: ArrayOps = NUMPY_NAN
) -> tuple[Any, Any, Any]:
    """The stripe coordinate s (f / period + phase) and the pixel's footprint (``a``, ``b``,
    as for :func:`coverage_formula`) with s put exactly on its nearest stripe edge, and the
    footprint set to 0, where s lies within :data:`SETTLE_ULPS` single-precision ulps of s
    (at least 2^-20 periods) of that edge and the footprint is narrower still; elsewhere as
    they are.

    A constant f (a plane under isophotes or reflection lines) carries single-precision
    round-off from the renderer's textures, in its value and in its slopes (exactly 0 in
    some cells, a few ulps in others): on an edge, that noise alone would pick each pixel's
    colour (salt and pepper, or bands of half-grey).  Settled, every such pixel is the same
    point sample on the edge, hence of the same colour (the edge's dark side: a rise at an
    integer, the light one at a fall).  A footprint wider than the noise is filtered as it
    is.  Use float64.

    Examples
    --------
    >>> import numpy as np
    >>> s = 10.0 + np.array([-3e-7, 0.0, 4e-7, 1e-3])
    >>> settled, a, b = settled_on_edges(s, np.full(4, 1e-9), np.zeros(4), 0.5)
    >>> settled.tolist(), a.tolist()
    ([10.0, 10.0, 10.0, 10.001], [0.0, 0.0, 0.0, 1e-09])
    """
    whole = ops.floor(s)
    t = s - whole
    offset = edge_offset(s, duty, ops)
    tol = ops.maximum(ops.abs(s) * (SETTLE_ULPS * 2.0**-24), 2.0**-20)
    settle = (ops.abs(offset) <= tol) & ((ops.abs(a) + ops.abs(b)) <= tol)
    return (
        ops.select(settle, whole + (t + offset), s),
        ops.select(settle, 0.0 * a, a),
        ops.select(settle, 0.0 * b, b),
    )


def _dark_side(cdf: Any, at_fall: Any, ops: ArrayOps) -> Any:
    """The dark fraction of a distribution whose mass left of an edge is ``cdf``."""
    return ops.select(at_fall, cdf, 1.0 - cdf)


def trapezoid_cdf(x: Any, a: Any, b: Any, ops: ArrayOps = NUMPY_NAN) -> Any:
    """The mass below x of a pixel's footprint a X + b Y (X, Y uniform on [-1/2, 1/2],
    a >= b >= 0): the trapezoid distribution's CDF, exact to a few eps at any footprint
    down to 0 (1/2 - |x| / a on its flat part, ((a + b) / 2 - |x|)^2 / (2 a b) on a ramp,
    mirrored for x > 0).  At x = 0 with no footprint: 0 (a value exactly at a level lies
    above it).

    Examples
    --------
    >>> import numpy as np
    >>> trapezoid_cdf(np.array([-1.0, -0.25, 0.0, 0.25, 1.0]), 1.0, 0.0).tolist()
    [0.0, 0.25, 0.5, 0.75, 1.0]
    >>> trapezoid_cdf(np.array([0.0, 1e-300]), 0.0, 0.0).tolist()
    [0.0, 1.0]
    """
    hi, lo = (a + b) / 2, (a - b) / 2
    safe_a = ops.select(a > 0, a, 1.0)
    safe_b = ops.select(b > 0, b, 1.0)
    u = ops.abs(x)
    r = (hi - ops.minimum(u, hi)) / safe_b
    beyond = ops.select(u < lo, 0.5 - u / safe_a, r * r * (b / (2.0 * safe_a)))  # mass past |x|
    return ops.select(x > 0, 1.0 - beyond, beyond)


def coverage_formula(s: Any, a: Any, b: Any, duty: float, ops: ArrayOps = NUMPY_NAN) -> Any:
    """The box-filtered stripe coverage (see :func:`stripe_coverage`), written once for any
    array library through ``ops`` (:class:`gshade.runtime.backend.ArrayOps`; floor, minimum,
    maximum, abs, select): numpy's here, Dr.Jit's in the renderer.  Use float64.

    The pixel's footprint in s is the trapezoid distribution of s + a X + b Y (X, Y uniform
    on [-1/2, 1/2], a >= b >= 0): support half-width hi = (a + b) / 2, flat on [-lo, lo],
    lo = (a - b) / 2, linear ramps of width b.  With m = min(duty, 1 - duty) (the shortest
    stripe) and eps = 2^-52, four exact formulas, none of which cancels badly:

    * clear (the footprint reaches no edge, including a = b = 0): the indicator at s;
    * a + b <= m (at most one edge in the footprint, the nearest one, at x from s): the
      trapezoid's CDF at x, piecewise (1/2 - |x|/a on the flat, ((hi - |x|)/b)^2 b/(2a) on
      a ramp).  x is exact up to one rounding (s - floor(s) is carried with its rounding
      error), so the error is a few eps, at any footprint down to 0;
    * b <= m < a + b: the flat part (Q(s + lo) - Q(s - lo)) / a plus the two ramps, each a
      triangle of width b that meets at most one edge (its CDF at that edge): error
      <= ~5 eps (1 + a) / a < 15 eps / m;
    * b > m: duty + the second difference of the periodic part B of Q2 over a b, every B at
      an argument in [0, 1): error <= eps (2 + a) / (a b) < 3 eps / m^2.

    So the coverage is the exact mean of the indicator over the footprint (for the float s,
    a, b given) to 3 eps / m^2 + 15 eps / m: 1e-13 for duty in [0.1, 0.9], and below 1e-6
    while m >= 3e-5.  (The earlier difference of Q2 over arguments of order 1 lost
    ~1e-16 / (a b): 1e-4 for a footprint of 1e-6 at an edge.)"""
    a, b = ops.abs(a), ops.abs(b)
    a, b = ops.maximum(a, b), ops.minimum(a, b)
    m = min(duty, 1.0 - duty)
    hi, lo = (a + b) / 2, (a - b) / 2
    safe_a = ops.select(a > 0, a, 1.0)
    safe_b = ops.select(b > 0, b, 1.0)
    half_ramp = b / (2.0 * safe_a)  # the mass of each ramp
    # s - floor(s), and its rounding error (nonzero only for -1/2 < s < 0): both filters are
    # invariant under whole periods, and a tiny footprint needs the edge to the last bit
    t, t_err = _two_sum(s, -ops.floor(s))
    x, at_fall = _nearest_edge(t, duty, ops)
    x = x - t_err
    hard = ops.select(at_fall, ops.select(x > 0, 1.0, 0.0), ops.select(x <= 0, 1.0, 0.0))
    clear = ops.abs(x) >= hi

    # at most one edge: the trapezoid's mass left of it
    local = _dark_side(trapezoid_cdf(x, a, b, ops), at_fall, ops)

    # flat part and two ramps (b <= m: each ramp meets at most one edge)
    flat = (_primitive(t + lo, duty, ops) - _primitive(t - lo, duty, ops)) / safe_a
    right = t + a / 2  # the right ramp's centre: density falls to 0 across it
    y, right_fall = _nearest_edge(right - ops.floor(right), duty, ops)
    v = ops.clip((0.5 * b - y) / safe_b, 0.0, 1.0)
    right_dark = _dark_side(1.0 - v * v, right_fall, ops)
    left = t - a / 2  # the left ramp's centre: density rises from 0 across it
    y, left_fall = _nearest_edge(left - ops.floor(left), duty, ops)
    v = ops.clip((0.5 * b + y) / safe_b, 0.0, 1.0)
    left_dark = _dark_side(v * v, left_fall, ops)
    ramps = flat + half_ramp * (right_dark + left_dark)

    # wide in both directions: duty plus the second difference of B
    second = (
        _periodic_part(t + hi, duty, ops)
        - _periodic_part(t + lo, duty, ops)
        - _periodic_part(t - lo, duty, ops)
        + _periodic_part(t - hi, duty, ops)
    )
    wide = duty + second / (safe_a * safe_b)

    cov = ops.select(b > m, wide, ops.select(a + b > m, ramps, local))
    cov = ops.select(clear, hard, cov)
    return ops.minimum(ops.maximum(cov, 0.0), 1.0)


def stripe_coverage(
    s: ArrayLike, width: ArrayLike = 0.0, width_y: ArrayLike | None = None, *, duty: float = 0.5
) -> NDArray:
    """Fraction of a pixel lying on dark stripes (fract(s) < duty), box-filtered.

    Parameters
    ----------
    s : array_like
        Stripe coordinate (f / period + phase) at the pixel centre.
    width : array_like
        With ``width_y`` None: the footprint width in units of s (the 1-D box filter over
        [s - w/2, s + w/2]).  Otherwise the change of s across the pixel in x, |ds/dx|.
    width_y : array_like, optional
        The change of s across the pixel in y, |ds/dy|.  Then the coverage is the exact
        mean of the stripe indicator over the square pixel for s linear in the pixel:
        the second difference of Q2 over the trapezoid of widths |ds/dx| and |ds/dy|.
    duty : float
        Fraction of each period that is dark, in (0, 1).

    Notes
    -----
    Where the stripes are denser than the pixels the coverage tends to ``duty``: a uniform
    grey instead of moiré.  Zero widths give the hard (aliased) indicator.
    """
    if not 0.0 < duty < 1.0:
        raise GshadeError(f"duty: expected a number in (0, 1), got {duty!r}")
    s = np.asarray(s, dtype=np.float64)
    a = np.broadcast_to(np.asarray(width, dtype=np.float64), s.shape)
    b = (
        np.zeros_like(a)
        if width_y is None
        else np.broadcast_to(np.asarray(width_y, float), s.shape)
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.asarray(coverage_formula(s, a, b, float(duty)), dtype=np.float64)


def stripe_period(
    period: float | None, count: float | None, value_range: tuple[float, float] | None
) -> float:
    """The stripe period: given, or the value range divided by a stripe count."""
    if period is not None and count is None:
        if not (np.isfinite(period) and period > 0):
            raise GshadeError(f"period: expected a positive number, got {period!r}")
        return float(period)
    if count is not None and period is None:
        if not (np.isfinite(count) and count > 0):
            raise GshadeError(f"stripes: expected a positive stripe count, got {count!r}")
        lo, hi = validate_range(value_range)
        return (hi - lo) / float(count)
    raise GshadeError("stripes: expected exactly one of period or count (stripes)")


def stripes(
    f: ArrayLike,
    period: float,
    *,
    footprint: ArrayLike = 0.0,
    duty: float = 0.5,
    phase: float = 0.0,
    dark: ArrayLike = DARK,
    light: ArrayLike = LIGHT,
) -> tuple[NDArray, NDArray]:
    """Anti-aliased stripes of f.

    Parameters
    ----------
    f : array_like
        Shape-function values.
    period : float
        Stripe period in units of f.
    footprint : array_like
        Pixel footprint in units of f (e.g. |grad_S f| times the pixel's size on the surface).
    duty, phase : float
        Dark fraction of a period; offset in periods.
    dark, light : RGB
        The two colours.

    Returns
    -------
    rgb : ndarray, shape (..., 3)
    coverage : ndarray, shape (...)
        The dark fraction of each pixel.
    """
    if not (np.isfinite(period) and period > 0):
        raise GshadeError(f"period: expected a positive number, got {period!r}")
    f = np.asarray(f, dtype=np.float64)
    cov = stripe_coverage(
        f / period + phase, np.asarray(footprint, dtype=np.float64) / period, duty=duty
    )
    rgb = cov[..., None] * np.asarray(dark) + (1.0 - cov[..., None]) * np.asarray(light)
    return rgb, cov


def validate_range(value_range: Any) -> tuple[float, float]:
    """A colour-map range ``[min, max]``: two finite numbers, min < max, as floats.

    Raises
    ------
    GshadeError
        ``range: expected [min, max] ...``, naming the range as given.
    """
    try:
        lo, hi = (float(x) for x in value_range)
    except (TypeError, ValueError):
        raise GshadeError(
            f"range: expected [min, max], two numbers, got {show(value_range)}"
        ) from None
    if not (np.isfinite(lo) and np.isfinite(hi)):
        raise GshadeError(
            f"range: expected [min, max], two finite numbers, got {show(value_range)}"
        )
    if not lo < hi:
        raise GshadeError(f"range: expected [min, max] with min < max, got {show(value_range)}")
    return lo, hi


def auto_range(
    f: ArrayLike,
    valid: ArrayLike | None = None,
    *,
    signed: bool = False,
    percentiles: tuple[float, float] = (1.0, 99.0),
    weights: ArrayLike | None = None,
) -> tuple[float, float]:
    """A robust value range: the given percentiles of the valid values, symmetric about 0
    (±max |percentile|) for signed functions.  Never empty.

    With ``weights`` (>= 0, e.g. the surface area each value stands for), the percentiles
    are of the weighted distribution, estimated from at most ``2**20`` evenly strided
    values."""
    f = np.asarray(f, dtype=np.float64)
    mask = np.isfinite(f) if valid is None else (np.asarray(valid, bool) & np.isfinite(f))
    values = f[mask]
    if values.size == 0:
        return (-1.0, 1.0) if signed else (0.0, 1.0)
    if weights is not None:
        w = np.asarray(weights, dtype=np.float64)[mask]
        stride = max(1, values.size >> 20)
        values, w = values[::stride], w[::stride]
        order = np.argsort(values)
        values, cumulative = values[order], np.cumsum(w[order])
    if weights is not None and cumulative[-1] > 0:
        at = np.searchsorted(cumulative / cumulative[-1], np.asarray(percentiles) / 100.0)
        lo, hi = (float(values[min(i, values.size - 1)]) for i in at)
    else:
        lo, hi = (float(x) for x in np.percentile(values, percentiles))
    if signed:
        m = max(abs(lo), abs(hi))
        lo, hi = -m, m
    if not hi > lo:
        pad = max(abs(hi), 1.0) * 1e-6
        lo, hi = lo - pad, hi + pad
    return lo, hi


@dataclass(frozen=True)
class ColourMapped:
    """Colours of a colour-mapped function and what the mapping did."""

    rgb: NDArray
    value_range: tuple[float, float]
    below: int
    above: int
    undefined: int


def colour_map(
    f: ArrayLike,
    valid: ArrayLike | None = None,
    *,
    value_range: tuple[float, float] | None = None,
    signed: bool = False,
    cmap: str | None = None,
) -> ColourMapped:
    """Map values to colours; values outside the range clamp, and are counted.

    Parameters
    ----------
    f : array_like
    valid : array_like of bool, optional
        Where f is defined; other points get the ``UNDEFINED`` colour.
    value_range : (min, max), optional
        Fixed range (so that images are comparable); default :func:`auto_range`.
    signed : bool
        Use a range symmetric about 0 and a diverging map (default 'coolwarm').
    cmap : str, optional
        Any matplotlib colour map name (default 'viridis', or 'coolwarm' if signed).
    """
    import matplotlib

    f = np.asarray(f, dtype=np.float64)
    ok = np.isfinite(f) if valid is None else (np.asarray(valid, bool) & np.isfinite(f))
    lo, hi = (
        auto_range(f, ok, signed=signed) if value_range is None else validate_range(value_range)
    )
    colours = matplotlib.colormaps[validate_colormap(cmap or ("coolwarm" if signed else "viridis"))]
    t = (f - lo) / (hi - lo)
    below = int(np.count_nonzero(ok & (t < 0)))
    above = int(np.count_nonzero(ok & (t > 1)))
    t = np.clip(np.where(ok, t, 0.0), 0.0, 1.0)
    # matplotlib's maps are sRGB; the renderer works in linear RGB
    rgb = srgb_to_linear(colours(t)[..., :3])
    rgb[~ok] = UNDEFINED
    return ColourMapped(rgb, (lo, hi), below, above, int(np.count_nonzero(~ok)))


def srgb_to_linear(c: NDArray) -> NDArray:
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def combine(rgb: ArrayLike, coverage: ArrayLike, strength: float = 0.65) -> NDArray:
    """Colour from one function, stripes from another: darken ``rgb`` by the stripe coverage."""
    rgb = np.asarray(rgb, dtype=np.float64)
    return rgb * (1.0 - strength * np.asarray(coverage, dtype=np.float64))[..., None]


@dataclass(frozen=True)
class Legend:
    """What a picture shows, for legends, colour bars, figure captions and EXR headers."""

    function: str
    order: int
    display: str  # 'stripes' | 'colormap' | 'both' | 'bands' | 'reflection'
    value_range: tuple[float, float] | None = None
    colormap: str | None = None
    period: float | None = None
    duty: float | None = None
    stripe_function: str | None = None
    clamped_below: int = 0
    clamped_above: int = 0
    units: str = ""
    bands: str | None = None  # display = 'bands': the bands in words
    #: what else the picture shows or the render found, a phrase each (the combs' scale,
    #: the smallest radius)
    notes: tuple[str, ...] = ()

    def as_dict(self) -> dict:
        out = {k: v for k, v in asdict(self).items() if v is not None and k != "notes"}
        if self.notes:
            out["notes"] = list(self.notes)
        return out

    def text(self) -> str:
        """One line for a caption, e.g. 'mean (order 2), coolwarm on [-1.2, 1.2] 1/length'."""
        parts = [f"{self.function} (order {self.order})"]
        if self.display in ("colormap", "both") and self.value_range is not None:
            lo, hi = self.value_range
            parts.append(f"{self.colormap} on [{lo:.4g}, {hi:.4g}] {self.units}".rstrip())
        if self.display in ("stripes", "both") and self.period is not None:
            of = f" of {self.stripe_function}" if self.stripe_function else ""
            parts.append(f"stripes{of} every {self.period:.4g}")
        if self.display == "bands" and self.bands is not None:
            parts.append(f"bands: {self.bands}")
        return "; ".join([", ".join(parts), *self.notes])
