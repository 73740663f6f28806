"""Continuity at patch junctions, measured (Kiciak, ch. 2–3): ``gshade continuity``.

Every pair of patches sharing a boundary (in either orientation, within the G0 tolerance)
is sampled along it, and at each sample both patches' exact derivatives give:

- ``gap``: |p_i - p_j| (G0);
- ``normal_angle_deg``: the angle between the normals, orientation aside (G1);
- ``curvature_jump``: the largest jump of the normal curvature over tangent directions
  (the shape operators compared, like OpenCASCADE's G2 measure) (G2);
- ``curvature_gradient_jump``: the largest jump of the surface gradients of the mean and
  Gaussian curvature (G3).

The curvature formulas are :mod:`gshade.geometry.differential`'s (normal curvature) and the
shape functions' ``mean`` and ``gaussian`` (their exact surface gradients).

A junction's class is the highest of G0, G1, G2, G3 whose measures all lie below their
tolerances (``none`` if even the gap is larger).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError, show
from ..geometry import Patch, regularised_derivatives, unit_normal
from ..geometry.differential import IRREGULAR_TOL, _cross, _dot, normal_curvature
from ..geometry.patch import unit_to_domain
from ..limits import MAX_CONTINUITY_SAMPLES
from ..shape import evaluate

if TYPE_CHECKING:
    from .knot_lines import KnotLine

__all__ = [
    "Junction",
    "Tolerances",
    "continuity_report",
    "find_junctions",
    "junction_between",
    "validate_samples",
]

SIDES = ("u0", "u1", "v0", "v1")
CLASSES = ("none", "G0", "G1", "G2", "G3")
MAX_PARTNERS = 8  # boundaries one boundary may coincide with (a manifold edge: one)
MAX_SAMPLES = MAX_CONTINUITY_SAMPLES  # samples per junction (gshade.limits)
MAX_PAIRS = 10_000  # explicitly given pairs


@dataclass(frozen=True)
class Tolerances:
    """Absolute tolerances: gap (length), normal angle (degrees), curvature jump (1/length),
    curvature-gradient jump (1/length^2)."""

    g0: float
    g1: float = 1e-3
    g2: float = 1e-4
    g3: float = 1e-3

    @classmethod
    def for_size(cls, diagonal: float, **given) -> Tolerances:
        """Defaults scaled to a surface of the given bounding-box diagonal."""
        d = diagonal or 1.0
        base = {"g0": 1e-7 * d, "g1": 1e-3, "g2": 1e-5 / d, "g3": 1e-4 / d**2}
        base.update({k: v for k, v in given.items() if v is not None})
        for key, value in base.items():
            if not (value >= 0):
                raise GshadeError(f"tolerance {key}: expected a number >= 0, got {value!r}")
        return cls(**base)


@dataclass
class Junction:
    """A measured junction: two patches' sides, or (``edge`` set) a B-rep edge of a CAD
    model between two faces (``patches`` the face numbers; no sides), or (``knot`` set) an
    interior knot line of one B-spline patch or face (``patches`` its number twice; no
    sides; :mod:`gshade.analysis.knot_lines`)."""

    patches: tuple[int, int]
    sides: tuple[str, str] | None
    reversed: bool
    cls: str
    gap: float
    normal_angle_deg: float
    curvature_jump: float
    curvature_gradient_jump: float
    samples: int
    edge: int | None = None
    knot: KnotLine | None = None

    def as_dict(self) -> dict:
        d = asdict(self)
        d["class"] = d.pop("cls")
        d["patches"] = list(self.patches)
        d.pop("knot")
        if self.knot is not None:
            for key in ("sides", "reversed", "edge"):
                d.pop(key)
            d.update(self.knot.as_dict(self.patches[0]))
        elif self.edge is None:
            d.pop("edge")
            d["sides"] = list(self.sides or ())
        else:
            d.pop("sides")
            d.pop("reversed")
        return d


def _side_params(patch: Patch, side: str, t: NDArray) -> tuple[NDArray, NDArray]:
    (u0, u1), (v0, v1) = patch.domain
    u, v = unit_to_domain(patch.domain, t, t)
    if side in ("u0", "u1"):
        return np.full_like(t, u0 if side == "u0" else u1), v
    return u, np.full_like(t, v0 if side == "v0" else v1)


def _side_points(patch: Patch, side: str, t: NDArray) -> NDArray:
    return patch(*_side_params(patch, side, t))


def _sides_params(patch: Patch, t: NDArray) -> tuple[NDArray, NDArray]:
    """(u, v) of ``t`` along the four sides u0, u1, v0, v1 in turn (as :func:`_side_params`)."""
    (u0, u1), (v0, v1) = patch.domain
    u, v = unit_to_domain(patch.domain, t, t)
    n = len(t)
    return (
        np.concatenate([np.full(n, float(u0)), np.full(n, float(u1)), u, u]),
        np.concatenate([v, v, np.full(n, float(v0)), np.full(n, float(v1))]),
    )


def _probe_sides(patches, tolerance: float, probes: int) -> tuple[list, NDArray]:
    """Every boundary that is not collapsed: its (patch, side) and its probe points."""
    t = np.linspace(0.0, 1.0, probes)
    points = np.empty((len(patches), len(SIDES), probes, 3))
    for i, patch in enumerate(patches):
        points[i] = np.asarray(patch(*_sides_params(patch, t)), float).reshape(-1, probes, 3)
    spread = (points.max(axis=2) - points.min(axis=2)).max(axis=2)
    kept = np.argwhere(spread > tolerance)  # collapsed edges join nothing
    names = [(int(i), SIDES[k]) for i, k in kept]
    return names, points[kept[:, 0], kept[:, 1]].reshape(-1, probes, 3)


def _verified(points: NDArray, a: NDArray, b: NDArray, tolerance: float):
    """Which candidate pairs (a, b) of sides coincide, and which of those reversed."""
    same = np.empty(len(a), dtype=bool)
    flipped = np.empty(len(a), dtype=bool)
    for k in range(0, len(a), 65536):  # bounded temporaries
        pa, pb = points[a[k : k + 65536]], points[b[k : k + 65536]]
        same[k : k + 65536] = np.abs(pa - pb).max(axis=(1, 2)) <= tolerance
        flipped[k : k + 65536] = np.abs(pa - pb[:, ::-1]).max(axis=(1, 2)) <= tolerance
    return same | flipped, flipped & ~same


def find_junctions(
    patches, tolerance: float, probes: int = 5, max_partners: int = MAX_PARTNERS
) -> list[tuple[int, str, int, str, bool]]:
    """(i, side_i, j, side_j, reversed) for every pair of coinciding patch boundaries.

    Two boundaries coincide when their ``probes`` points (an odd number, evenly spaced)
    agree within ``tolerance`` in every coordinate, in the same or the reversed order.
    Candidates come from a k-d tree of the boundaries' middle points (the middle point is
    the same in both orders): each boundary's ``max_partners + 1`` nearest, all of those
    within reach only where that many middle points meet (then refused, unless the
    boundaries just cross there).  The search takes O(S log S) for S boundaries; the result
    is ordered as the boundaries are (patch, then side u0 u1 v0 v1).

    Raises
    ------
    GshadeError
        If a boundary coincides with more than ``max_partners`` others (a manifold edge
        joins one): overlapping or duplicated surfaces, named by the first such boundary.
    """
    from scipy.spatial import cKDTree

    if probes < 3 or probes % 2 == 0:
        raise ValueError(f"probes: expected an odd number >= 3, got {probes}")
    names, points = _probe_sides(patches, tolerance, probes)
    count = len(names)
    if count < 2:
        return []
    mids = points[:, probes // 2]
    tree = cKDTree(mids)
    radius = np.nextafter(tolerance * (1 + 1e-9), np.inf)  # a superset; verified below
    # the max_partners + 1 nearest others of each boundary: all a manifold needs
    k = min(count, max_partners + 2)
    _, nearest = tree.query(mids, k=k, p=np.inf, distance_upper_bound=radius)
    near = np.asarray(nearest)  # (count, k) indices; count where fewer were within reach
    a = np.repeat(np.arange(count), k)
    b = near.reshape(-1)
    keep = (b < count) & (a != b)
    a, b = np.minimum(a[keep], b[keep]), np.maximum(a[keep], b[keep])
    patch_of = np.array([i for i, _ in names])
    pairs = np.unique(np.stack([a, b], axis=1), axis=0).reshape(-1, 2)
    pairs = pairs[patch_of[pairs[:, 0]] != patch_of[pairs[:, 1]]]
    ok, rev = _verified(points, pairs[:, 0], pairs[:, 1], tolerance)
    found = dict(zip(map(tuple, pairs[ok].tolist()), rev[ok].tolist(), strict=True))
    # a boundary whose k nearest are all within reach may have more partners: look at all
    for s in np.flatnonzero(near[:, -1] < count):
        others = np.array(sorted(tree.query_ball_point(mids[s], radius, p=np.inf)), dtype=int)
        others = others[patch_of[others] != patch_of[s]]
        ok, rev = _verified(points, np.full(len(others), s), others, tolerance)
        if ok.sum() > max_partners:
            i, side = names[s]
            raise GshadeError(
                f"patch {i} side {side}: its boundary coincides with {int(ok.sum())} other "
                f"boundaries (a junction joins one, at most {max_partners} are accepted): "
                f"overlapping or duplicated surfaces"
            )
        for o, r in zip(others[ok].tolist(), rev[ok].tolist(), strict=True):
            found[(min(s, o), max(s, o))] = r
    return [(*names[a], *names[b], rev) for (a, b), rev in sorted(found.items())]


def junction_between(
    patches, i: int, side_i: str, j: int, side_j: str, tolerance: float, probes: int = 9
) -> tuple[int, str, int, str, bool]:
    """The junction (i, side_i, j, side_j, reversed) of two given boundaries.

    Raises GshadeError naming the pair when a patch or side does not exist, or when the two
    boundaries do not coincide within ``tolerance`` in either orientation.
    """
    name = f"pair {i}:{side_i},{j}:{side_j}"
    for k, side in ((i, side_i), (j, side_j)):
        if not 0 <= k < len(patches):
            raise GshadeError(
                f"{name}: patch {k}: expected a patch index from 0 to {len(patches) - 1}"
            )
        if side not in SIDES:
            raise GshadeError(f"{name}: side {side!r}: expected one of {', '.join(SIDES)}")
    if i == j:
        raise GshadeError(f"{name}: expected two different patches")
    t = np.linspace(0.0, 1.0, probes)
    a = _side_points(patches[i], side_i, t)
    b = _side_points(patches[j], side_j, t)
    same = float(np.linalg.norm(a - b, axis=-1).max())
    flipped = float(np.linalg.norm(a - b[::-1], axis=-1).max())
    if min(same, flipped) > tolerance:
        raise GshadeError(
            f"{name}: the boundaries do not match: they are {min(same, flipped):.3g} apart "
            f"at the most (in the closer orientation), more than the G0 tolerance {tolerance:.3g}"
        )
    return i, side_i, j, side_j, flipped < same


def _geometry(patch: Patch, side: str, t: NDArray):
    return geometry_at(patch, *_side_params(patch, side, t))


def geometry_at(patch: Patch, u: NDArray, v: NDArray):
    """Derivatives to order 3 (regularised where the patch is irregular), unit normals, and
    the mean and Gaussian curvatures (with their surface gradients) at (u, v)."""
    return geometry_of(regularised_derivatives(patch, u, v, 3).d)


def geometry_of(d: NDArray):
    """:func:`geometry_at` from the derivatives d (4, 4, ..., 3) themselves."""
    n = unit_normal(d).n
    mean = evaluate("mean", d)
    gauss = evaluate("gaussian", d)
    return d, n, mean, gauss


def measure(patches, junction, samples: int = 32, directions: int = 8) -> dict:
    """The four measures along one junction."""
    i, si, j, sj, rev = junction
    t = (np.arange(samples) + 0.5) / samples
    di, ni, hi, ki = _geometry(patches[i], si, t)
    dj, nj, hj, kj = _geometry(patches[j], sj, t[::-1] if rev else t)
    gap = float(np.linalg.norm(di[0, 0] - dj[0, 0], axis=-1).max())
    # atan2 of |cross| and |dot|: accurate for tiny angles (arccos is not)
    angle = float(
        np.degrees(
            np.arctan2(np.linalg.norm(np.cross(ni, nj), axis=-1), np.abs(np.sum(ni * nj, -1)))
        ).max()
    )
    sign = np.sign(np.sum(ni * nj, -1))[:, None]  # curvatures w.r.t. one orientation
    # tangent frame: along the boundary, and across it in patch i's tangent plane
    along = di[1, 0] if si in ("v0", "v1") else di[0, 1]
    along = along / np.linalg.norm(along, axis=-1, keepdims=True)
    across = np.cross(ni, along)
    jump = 0.0
    for theta in np.linspace(0.0, np.pi, directions, endpoint=False):
        e = np.cos(theta) * along + np.sin(theta) * across
        k_i = normal_curvature(di, ni, e)
        k_j = normal_curvature(dj, nj, e) * sign[:, 0]
        jump = max(jump, float(np.abs(k_i - k_j).max()))
    grad_h = np.linalg.norm(hi.gradient - sign * hj.gradient, axis=-1)
    grad_k = np.linalg.norm(ki.gradient - kj.gradient, axis=-1)
    gradient_jump = float(max(grad_h.max(), grad_k.max()))
    return {
        "gap": gap,
        "normal_angle_deg": angle,
        "curvature_jump": jump,
        "curvature_gradient_jump": gradient_jump,
    }


def _side_geometry(patches, sides: list[tuple[int, str]], t: NDArray):
    """:func:`_geometry` of many (patch, side)s: d (4, 4, S, n, 3), normals, and the mean
    and Gaussian curvatures' surface gradients (S, n, 3), equal to it point by point.

    Each patch is evaluated once for all its sides.  A side takes the batched path only
    where :func:`_geometry` would do no more than that: every point regular at the side's
    own derivative scale (no regularisation, plain normals), and every point clearly valid
    at the batch's scale in ``evaluate`` (whose threshold comes from the largest first
    derivative of what it is given).  Other sides are measured by :func:`_geometry` itself.
    """
    count, n = len(sides), len(t)
    d = np.empty((4, 4, count, n, 3))
    by_patch: dict[int, list[int]] = {}
    for k, (i, _) in enumerate(sides):
        by_patch.setdefault(i, []).append(k)
    for i, ks in by_patch.items():
        params = [_side_params(patches[i], sides[k][1], t) for k in ks]
        u = np.concatenate([q[0] for q in params])
        v = np.concatenate([q[1] for q in params])
        d[:, :, ks] = np.asarray(patches[i].derivatives(u, v, 3)).reshape(4, 4, len(ks), n, 3)
    with np.errstate(all="ignore"):
        pu, pv = d[1, 0], d[0, 1]
        N = _cross(pu, pv)
        W2 = _dot(N, N)
        length = np.sqrt(W2)
        scale = np.maximum(np.abs(pu).max(axis=(1, 2)), np.abs(pv).max(axis=(1, 2)))
        scale = np.where(scale > 0, scale, 1.0)
        fast = np.isfinite(d).all(axis=(0, 1, 3, 4))
        fast &= (length > IRREGULAR_TOL * scale[:, None] ** 2).all(axis=1)
        if fast.any():
            limit = IRREGULAR_TOL * scale[fast].max() ** 2
            fast &= (W2 > 1.01 * limit * limit).all(axis=1)
    normal = N / np.where(fast[:, None], length, 1.0)[..., None]
    mean, gauss = np.empty((count, n, 3)), np.empty((count, n, 3))
    if fast.any():
        mean[fast] = evaluate("mean", d[:, :, fast]).gradient
        gauss[fast] = evaluate("gaussian", d[:, :, fast]).gradient
    for k in np.flatnonzero(~fast).tolist():
        i, side = sides[k]
        dk, nk, hk, kk = _geometry(patches[i], side, t)
        d[:, :, k], normal[k], mean[k], gauss[k] = dk, nk, hk.gradient, kk.gradient
    return d, normal, mean, gauss


def _pick(a: NDArray, b: NDArray) -> NDArray:
    """Python's max(a, b) element-wise: b only where it is larger (a NaN b is passed over)."""
    return np.where(b > a, b, a)


def measure_all(patches, junctions, samples: int = 32, directions: int = 8) -> list[dict]:
    """:func:`measure` of every junction, batched (equal to it up to round-off)."""
    out: list[dict] = []
    chunk = max(1, 2**15 // samples)  # junctions at a time: bounded temporaries
    t = (np.arange(samples) + 0.5) / samples
    for start in range(0, len(junctions), chunk):
        part = junctions[start : start + chunk]
        index: dict[tuple[int, str], int] = {}
        for i, si, j, sj, _ in part:
            index.setdefault((i, si), len(index))
            index.setdefault((j, sj), len(index))
        d, n, h, k = _side_geometry(patches, list(index), t)
        a = np.array([index[(i, si)] for i, si, *_ in part])
        b = np.array([index[(j, sj)] for _, _, j, sj, _ in part])
        rev = np.array([r for *_, r in part], dtype=bool)
        flip = np.where(rev[:, None], np.arange(samples)[::-1], np.arange(samples))
        di, ni, hi, ki = d[:, :, a], n[a], h[a], k[a]
        bb = b[:, None]
        dj, nj, hj, kj = d[:, :, bb, flip], n[bb, flip], h[bb, flip], k[bb, flip]
        across_v = np.array([si in ("v0", "v1") for _, si, *_ in part])[:, None, None]
        along = np.where(across_v, di[1, 0], di[0, 1])
        gap, angle, jump, gradient_jump = compare_sides(
            (di, ni, hi, ki), (dj, nj, hj, kj), along, directions
        )
        for m in range(len(part)):
            out.append(
                {
                    "gap": float(gap[m]),
                    "normal_angle_deg": float(angle[m]),
                    "curvature_jump": float(jump[m]),
                    "curvature_gradient_jump": float(gradient_jump[m]),
                }
            )
    return out


def compare_sides(
    side_i: tuple, side_j: tuple, along: NDArray, directions: int = 8
) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """The four measures of many junctions from both sides' geometry at paired points.

    ``side_i`` and ``side_j`` are (d, n, mean gradient, Gaussian gradient) as
    :func:`_side_geometry` gives them, shapes (4, 4, J, S, 3), (J, S, 3), (J, S, 3),
    (J, S, 3), point s of junction m on side i paired with point s on side j; ``along``
    (J, S, 3) is a tangent of the junction on side i.  Returns each measure's largest value
    over each junction's points, (J,) each: gap, normal angle (degrees, orientation aside),
    normal-curvature jump over ``directions`` tangent directions, curvature-gradient jump.
    """
    di, ni, hi, ki = side_i
    dj, nj, hj, kj = side_j
    gap = np.linalg.norm(di[0, 0] - dj[0, 0], axis=-1).max(axis=-1)
    # atan2 of |cross| and |dot|: accurate for tiny angles (arccos is not)
    angle = np.degrees(
        np.arctan2(np.linalg.norm(np.cross(ni, nj), axis=-1), np.abs(np.sum(ni * nj, -1)))
    ).max(axis=-1)
    sign = np.sign(np.sum(ni * nj, -1))[..., None]  # curvatures w.r.t. one orientation
    length = np.linalg.norm(along, axis=-1, keepdims=True)
    if not (length > 0).all():  # no tangent (a degenerate sample): any tangent-plane frame
        along = np.where(length > 0, along, di[1, 0] + di[0, 1])
        length = np.linalg.norm(along, axis=-1, keepdims=True)
    along = along / length
    across = np.cross(ni, along)  # in side i's tangent plane
    jump = np.zeros(gap.shape)
    for theta in np.linspace(0.0, np.pi, directions, endpoint=False):
        e = np.cos(theta) * along + np.sin(theta) * across
        k_i = normal_curvature(di, ni, e)
        k_j = normal_curvature(dj, nj, e) * sign[..., 0]
        jump = _pick(jump, np.abs(k_i - k_j).max(axis=-1))
    grad_h = np.linalg.norm(hi - sign * hj, axis=-1).max(axis=-1)
    grad_k = np.linalg.norm(ki - kj, axis=-1).max(axis=-1)
    return gap, angle, jump, _pick(grad_h, grad_k)


def classify(m: dict, tol: Tolerances) -> str:
    if not m["gap"] <= tol.g0:
        return "none"
    if not m["normal_angle_deg"] <= tol.g1:
        return "G0"
    if not m["curvature_jump"] <= tol.g2:
        return "G1"
    if not m["curvature_gradient_jump"] <= tol.g3:
        return "G2"
    return "G3"


def validate_samples(samples: object) -> int:
    """The samples per junction, checked: an integer from 1 to
    :data:`gshade.limits.MAX_CONTINUITY_SAMPLES` (4096), for patch junctions and CAD edges
    alike.

    Raises
    ------
    GshadeError
        ``samples: expected 1 to 4096, got ...`` (the command line says ``--samples``).
    """
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)):
        raise GshadeError(
            f"samples: expected an integer from 1 to {MAX_SAMPLES}, got {show(samples)}"
        )
    if not 1 <= samples <= MAX_SAMPLES:
        raise GshadeError(f"samples: expected 1 to {MAX_SAMPLES}, got {samples}")
    return int(samples)


def continuity_report(
    patches,
    *,
    samples: int = 32,
    tolerances: Tolerances | None = None,
    pairs: list[tuple[int, str, int, str]] | None = None,
) -> list[Junction]:
    """Every junction of the patches, measured and classified, then every interior knot
    line of their B-spline patches (:func:`gshade.analysis.knot_lines.patch_knot_lines`);
    with ``pairs`` ((i, side_i, j, side_j), ...), just those, each checked to be a junction
    (:func:`junction_between`).

    Bounded: ``samples`` from 1 to ``MAX_SAMPLES`` (4096), at most ``MAX_PAIRS`` (10,000)
    pairs, and :func:`find_junctions` refuses a boundary shared by more than
    ``MAX_PARTNERS`` (8) others (so at most 4 x 8 junctions per patch are measured).
    """
    samples = validate_samples(samples)
    if pairs is not None and len(pairs) > MAX_PAIRS:
        raise GshadeError(f"pairs: expected at most {MAX_PAIRS} pairs, got {len(pairs)}")
    pts = np.concatenate([p(*p.parameter_grid(9, 9)).reshape(-1, 3) for p in patches])
    diag = float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))
    tol = tolerances or Tolerances.for_size(diag)
    out = []
    g0 = max(tol.g0, 1e-12 * diag)
    if pairs is None:
        junctions = find_junctions(patches, g0)
    else:
        junctions = [junction_between(patches, *pair, g0) for pair in pairs]
    for junction, m in zip(junctions, measure_all(patches, junctions, samples), strict=True):
        i, si, j, sj, rev = junction
        out.append(Junction((i, j), (si, sj), rev, classify(m, tol), samples=samples, **m))
    if pairs is None:  # and the B-spline patches' interior knot lines
        from .knot_lines import patch_knot_lines

        out.extend(patch_knot_lines(patches, samples=samples, tolerances=tol))
    return out
