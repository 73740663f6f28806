"""Continuity at patch junctions, measured (Kiciak, ch. 2–3): ``gshade continuity``.

Every pair of patches sharing a boundary (in either orientation, within the G0 tolerance)
is sampled along it, and at each sample both patches' exact derivatives give the four
measures of :mod:`gshade.analysis.junction_measures`:

- ``gap``: |p_i - p_j| (G0);
- ``normal_angle_deg``: the angle between the oriented normals, 0 to 180 degrees (G1;
  patch j oriented like patch i across the junction, :func:`flips_orientation`: a cusp or
  a fold is 180 degrees, G0);
- ``curvature_jump``: the largest jump of the normal curvature over tangent directions,
  exactly: the largest |eigenvalue| of the difference of the shape operators (G2);
- ``curvature_gradient_jump``: the largest jump of the surface gradients of the mean and
  Gaussian curvature (G3);

each with its estimated round-off and the sample where it is largest (``max_at``).

A junction's class is the highest of G0, G1, G2, G3 whose measures all lie below their
tolerances, each at least the measure's round-off (``none`` if even the gap is larger).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError, show
from ..geometry import Patch
from ..geometry.core.patch import unit_to_domain
from ..limits import MAX_CONTINUITY_SAMPLES
from .junction_measures import (
    MEASURES,
    SideGeometry,
    compare_sides,
    junction_fields,
    side_derivatives,
    side_geometry,
)

if TYPE_CHECKING:
    from collections.abc import Sequence

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
    def for_size(cls, diagonal: float, **given: float | None) -> Tolerances:
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
    model between two faces (``patches`` the face numbers; no sides; ``orientation``
    ``"consistent"`` or ``"inconsistent"``, whether the faces' orientations agree along the
    edge, :attr:`gshade.cad.edges.CadEdge.consistent`), or (``knot`` set) an interior
    knot line of one B-spline patch or face (``patches`` its number twice; no sides;
    :mod:`gshade.analysis.knot_lines`)."""

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
    round_off: dict | None = None
    max_at: dict | None = None
    orientation: str | None = None

    def as_dict(self) -> dict:
        """The JSON row: the fields above (``class`` for ``cls``; ``round_off``, each
        measure's estimated round-off, and ``max_at``, where each measure is largest, when
        measured: :func:`~gshade.analysis.junction_measures.junction_fields`)."""
        d = asdict(self)
        d["class"] = d.pop("cls")
        d["patches"] = list(self.patches)
        d.pop("knot")
        for key in ("round_off", "max_at", "orientation"):
            if d[key] is None:
                d.pop(key)
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


def _probe_sides(patches: Sequence[Patch], tolerance: float, probes: int) -> tuple[list, NDArray]:
    """Every boundary that is not collapsed: its (patch, side) and its probe points."""
    t = np.linspace(0.0, 1.0, probes)
    points = np.empty((len(patches), len(SIDES), probes, 3))
    for i, patch in enumerate(patches):
        points[i] = np.asarray(patch(*_sides_params(patch, t)), float).reshape(-1, probes, 3)
    spread = (points.max(axis=2) - points.min(axis=2)).max(axis=2)
    kept = np.argwhere(spread > tolerance)  # collapsed edges join nothing
    names = [(int(i), SIDES[k]) for i, k in kept]
    return names, points[kept[:, 0], kept[:, 1]].reshape(-1, probes, 3)


def _verified(
    points: NDArray, a: NDArray, b: NDArray, tolerance: float
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Which candidate pairs (a, b) of sides coincide, and which of those reversed."""
    same = np.empty(len(a), dtype=bool)
    flipped = np.empty(len(a), dtype=bool)
    for k in range(0, len(a), 65536):  # bounded temporaries
        pa, pb = points[a[k : k + 65536]], points[b[k : k + 65536]]
        same[k : k + 65536] = np.abs(pa - pb).max(axis=(1, 2)) <= tolerance
        flipped[k : k + 65536] = np.abs(pa - pb[:, ::-1]).max(axis=(1, 2)) <= tolerance
    return same | flipped, flipped & ~same


def find_junctions(
    patches: Sequence[Patch], tolerance: float, probes: int = 5, max_partners: int = MAX_PARTNERS
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
    patches: Sequence[Patch],
    i: int,
    side_i: str,
    j: int,
    side_j: str,
    tolerance: float,
    probes: int = 9,
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


#: The direction each side's loop runs along it, counter-clockwise in the (u, v) domain,
#: relative to its parameter t: +1 where t runs with the loop (v0: +u, u1: +v), -1 against.
_LOOP = {"v0": 1, "u1": 1, "v1": -1, "u0": -1}


def flips_orientation(side_i: str, side_j: str, reversed_: bool) -> bool:
    """Whether patch j's p_u x p_v is turned to orient it like patch i across a junction.

    Two patches are oriented alike when their counter-clockwise boundary loops run along the
    shared boundary in opposite directions (as the faces of an oriented surface do); the
    junction's ``reversed_`` says the two sides' parameters run opposite.  So j is turned
    where loop(i) x loop(j) x (-1 if reversed_) = +1.  The rule follows the patches, not their
    parametrisation: a patch reparametrised (u -> 1 - u) turns both its normal and its loop,
    and a smooth surface keeps its angles near 0 while a cusp or fold shows 180 degrees.
    """
    return _LOOP[side_i] * _LOOP[side_j] * (-1 if reversed_ else 1) == 1


def _side_geometry(
    patches: Sequence[Patch], sides: list[tuple[int, str]], t: NDArray
) -> SideGeometry:
    """Side geometry (:func:`~gshade.analysis.junction_measures.side_geometry`, p_u x p_v
    normals) of many (patch, side)s at ``t``: arrays (4, 4, S, n, 3), (S, n, 3), ...

    Each patch is evaluated once for all its sides, in its own scaled parametrisation
    (:func:`~gshade.analysis.junction_measures.side_derivatives`), and all sides' normals and
    curvatures in one batch.
    """
    count, n = len(sides), len(t)
    d = np.empty((4, 4, count, n, 3))
    error = np.empty((4, 4, count, n))
    by_patch: dict[int, list[int]] = {}
    for k, (i, _) in enumerate(sides):
        by_patch.setdefault(i, []).append(k)
    for i, ks in by_patch.items():
        params = [_side_params(patches[i], sides[k][1], t) for k in ks]
        u = np.concatenate([q[0] for q in params])
        v = np.concatenate([q[1] for q in params])
        dk, ek, _ = side_derivatives(patches[i], u, v, 3)
        d[:, :, ks] = dk.reshape(4, 4, len(ks), n, 3)
        error[:, :, ks] = ek.reshape(4, 4, len(ks), n)
    return side_geometry(d, error)


def measure(
    patches: Sequence[Patch], junction: tuple[int, str, int, str, bool], samples: int = 32
) -> dict:
    """The measures of one junction (:func:`measure_all` of it alone)."""
    return measure_all(patches, [junction], samples)[0]


def measure_all(
    patches: Sequence[Patch],
    junctions: Sequence[tuple[int, str, int, str, bool]],
    samples: int = 32,
) -> list[dict]:
    """The four measures of every junction (i, side_i, j, side_j, reversed), batched, each
    a dict of the measures, ``round_off`` and ``max_at``
    (:func:`~gshade.analysis.junction_measures.junction_fields`; ``t`` along side i, as
    sampled: (k + 1/2) / samples, ``uv`` patch i's).  Patch j is oriented like patch i
    across the junction (:func:`flips_orientation`)."""
    out: list[dict] = []
    chunk = max(1, 2**15 // samples)  # junctions at a time: bounded temporaries
    t = (np.arange(samples) + 0.5) / samples
    for start in range(0, len(junctions), chunk):
        part = junctions[start : start + chunk]
        index: dict[tuple[int, str], int] = {}
        for i, si, j, sj, _ in part:
            index.setdefault((i, si), len(index))
            index.setdefault((j, sj), len(index))
        g = _side_geometry(patches, list(index), t)
        a = np.array([index[(i, si)] for i, si, *_ in part])
        b = np.array([index[(j, sj)] for _, _, j, sj, _ in part])
        rev = np.array([r for *_, r in part], dtype=bool)
        flip = np.where(rev[:, None], np.arange(samples)[::-1], np.arange(samples))
        turn = np.array([-1.0 if flips_orientation(si, sj, r) else 1.0 for _, si, _, sj, r in part])
        bb = b[:, None]
        side_i = SideGeometry(
            g.d[:, :, a], g.n[a], g.mean_gradient[a], g.gauss_gradient[a], g.round_off[a]
        )
        side_j = SideGeometry(
            g.d[:, :, bb, flip],
            g.n[bb, flip] * turn[:, None, None],
            g.mean_gradient[bb, flip] * turn[:, None, None],
            g.gauss_gradient[bb, flip],
            g.round_off[bb, flip],
        )
        across_v = np.array([si in ("v0", "v1") for _, si, *_ in part])[:, None, None]
        along = np.where(across_v, side_i.d[1, 0], side_i.d[0, 1])
        cmp = compare_sides(side_i, side_j, along)
        uv = np.stack([np.stack(_side_params(patches[i], si, t), axis=-1) for i, si, *_ in part])
        for m in range(len(part)):
            measures, round_off, where = junction_fields(cmp, m, t, side_i.d[0, 0], uv)
            out.append({**measures, "round_off": round_off, "max_at": where})
    return out


def classify(m: dict, tol: Tolerances, round_off: dict | None = None) -> str:
    """The highest class whose measures all lie within their tolerances: each the larger of
    the given one and the measure's estimated round-off (``round_off``, by measure name;
    :mod:`gshade.analysis.junction_measures`), so that evaluation noise decides no class."""
    noise = round_off or {}
    for name, limit, below in zip(
        MEASURES, (tol.g0, tol.g1, tol.g2, tol.g3), CLASSES[:4], strict=True
    ):
        if not m[name] <= max(limit, noise.get(name, 0.0)):
            return below
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
    patches: Sequence[Patch],
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

    Examples
    --------
    A bicubic Bézier patch and the patch that continues it across its v = 1 edge with
    p*_v = 0.2 p_u + 1.5 p_v (:func:`gshade.geometry.splines.junctions.junction_patch`,
    Kiciak, ch. 3): the normals agree along the edge, the curvatures do not.

    >>> import numpy as np
    >>> from gshade.geometry import BezierPatch
    >>> from gshade.geometry.splines.junctions import junction_patch
    >>> x, y = np.meshgrid(np.arange(4.0), np.arange(4.0), indexing="ij")
    >>> p = BezierPatch(np.stack([x, y, np.sin(x + y)], axis=-1))
    >>> q = junction_patch(p, "G1", alpha=0.2, beta=1.5)
    >>> (junction,) = continuity_report([p, q])
    >>> junction.patches, junction.sides, junction.cls
    ((0, 1), ('v1', 'v0'), 'G1')
    >>> round(junction.gap, 12), round(junction.normal_angle_deg, 9)
    (0.0, 0.0)
    >>> round(junction.curvature_jump, 4)  # above the G2 tolerance
    0.1144
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
        cls = classify(m, tol, m["round_off"])
        out.append(Junction((i, j), (si, sj), rev, cls, samples=samples, **m))
    if pairs is None:  # and the B-spline patches' interior knot lines
        from .knot_lines import patch_knot_lines

        out.extend(patch_knot_lines(patches, samples=samples, tolerances=tol))
    return out
