"""Rhino ``.3dm`` files (openNURBS, through rhino3dm) as exact faces.

Every Brep face, extrusion (as a Brep) and free surface becomes a :class:`CadFace` whose patch
is the surface's own NURBS form.  openNURBS stores one knot fewer at each end than the
textbook vector; the end knots are repeated to pad it (they weigh on no basis function inside
the domain, so periodic, unclamped surfaces come out the same).

The Python bindings expose no 2D trimming curves: each loop is recovered by pulling the 3D
edge curves back into the NURBS form's (u, v) by point inversion (a grid search, then
Gauss-Newton).  Singular trims at poles (edge index -1) are bridged by the straight segment
between their neighbours, which is what they are in (u, v).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import rhino3dm
from numpy.typing import NDArray

from ..errors import GshadeError
from ..geometry.bspline import BSplinePatch
from ..limits import MAX_DATA_FILE_BYTES
from .cad import CadFace, CadModel
from .files import read_bytes

__all__ = ["read"]

_MAGIC = b"3D Geometry File Format "

_UNITS = {
    "Angstroms": "angstrom",
    "Nanometers": "nm",
    "Microns": "um",
    "Millimeters": "mm",
    "Centimeters": "cm",
    "Decimeters": "dm",
    "Meters": "m",
    "Dekameters": "dam",
    "Hectometers": "hm",
    "Kilometers": "km",
    "Megameters": "Mm",
    "Gigameters": "Gm",
    "Microinches": "uin",
    "Mils": "mil",
    "Inches": "in",
    "Feet": "ft",
    "Yards": "yd",
    "Miles": "mi",
    "NauticalMiles": "nmi",
    "AstronomicalUnits": "au",
    "LightYears": "ly",
    "Parsecs": "pc",
    "PrinterPoints": "pt",
    "PrinterPicas": "pica",
}

#: Edge samples per span and degree, and their bounds, for the recovered trimming loops.
_SAMPLES_PER_SPAN = 4
_MIN_SAMPLES, _MAX_SAMPLES = 9, 200
_GRID = 24
_NEWTON_STEPS = 30


def read(
    path: str | os.PathLike, sew: bool | None = None, tolerance: float | None = None
) -> CadModel:
    """Read a Rhino ``.3dm`` file into exact faces.

    Parameters
    ----------
    path : path-like
    sew, tolerance
        Ignored: a ``.3dm`` file stores its Breps already joined.

    Returns
    -------
    CadModel
        The faces in the order of the objects (Breps, extrusions, surfaces), the model's unit
        and the union of the surface objects' bounding boxes.

    Raises
    ------
    GshadeError
        One line naming the file: not a regular readable file, too large, not a 3dm file, a
        file openNURBS cannot read, or one that holds no surfaces.
    """
    path = Path(path)
    head = read_bytes(path, "a Rhino .3dm file", size=len(_MAGIC), limit=MAX_DATA_FILE_BYTES)
    if head != _MAGIC:
        raise GshadeError(f"{path}: expected a Rhino .3dm file, got no 3dm header")
    # rhino3dm's bundled stubs disagree with its bindings (iteration, GetBoundingBox): Any
    model: Any = rhino3dm.File3dm.Read(str(path))
    if model is None:
        raise GshadeError(f"{path}: openNURBS cannot read the file (damaged or truncated?)")
    faces: list[CadFace] = []
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for obj in model.Objects:
        geom: Any = obj.Geometry if obj is not None else None
        before = len(faces)
        if isinstance(geom, rhino3dm.Extrusion):
            geom = geom.ToBrep(False)
        if isinstance(geom, rhino3dm.Brep):
            for face in list(geom.Faces):  # type: ignore[call-overload]
                if face is not None:
                    faces.append(_brep_face(path, geom, face, len(faces)))
        elif isinstance(geom, rhino3dm.Surface):
            nurbs = geom.ToNurbsSurface()
            if nurbs is not None:
                faces.append(_surface_face(path, geom, nurbs, len(faces)))
        if geom is not None and len(faces) > before:
            box = geom.GetBoundingBox()
            if box is not None and box.IsValid:
                lo = np.minimum(lo, _xyz(box.Min))
                hi = np.maximum(hi, _xyz(box.Max))
    if not faces:
        raise GshadeError(f"{path}: expected surfaces (Breps, extrusions, NURBS), found none")
    return CadModel(path=path, faces=faces, unit=_unit(model), bounds=(lo, hi))


def _unit(model) -> str:
    """The model's length unit as a short name, or ``"unknown"``."""
    try:
        name = model.Settings.ModelUnitSystem.name
    except AttributeError:
        return "unknown"
    return _UNITS.get(name, "unknown")


def _xyz(p) -> NDArray[np.float64]:
    return np.array([p.X, p.Y, p.Z], dtype=np.float64)


def nurbs_patch(nurbs, where: Path | str = "surface") -> BSplinePatch:
    """A rhino3dm ``NurbsSurface`` as a :class:`BSplinePatch` (the same surface exactly).

    Raises
    ------
    GshadeError
        Naming ``where`` when the surface's data are inconsistent or not finite.
    """
    pts = nurbs.Points
    nu, nv = int(pts.CountU), int(pts.CountV)
    p, q = int(nurbs.OrderU) - 1, int(nurbs.OrderV) - 1
    rational = bool(nurbs.IsRational)
    h = np.array(
        [[_homogeneous(pts.GetControlPoint(i, j)) for j in range(nv)] for i in range(nu)],
        dtype=np.float64,
    ).reshape(nu, nv, 4)
    ku = np.asarray(nurbs.KnotsU.ToList(), dtype=np.float64)
    kv = np.asarray(nurbs.KnotsV.ToList(), dtype=np.float64)
    if len(ku) != nu + p - 1 or len(kv) != nv + q - 1:
        raise GshadeError(f"{where}: inconsistent NURBS surface (knot counts)")
    U = np.concatenate([ku[:1], ku, ku[-1:]])
    V = np.concatenate([kv[:1], kv, kv[-1:]])
    w = h[..., 3] if rational else None
    if w is not None and not np.all(w > 0):
        raise GshadeError(f"{where}: NURBS surface with non-positive weights")
    points = h[..., :3] / h[..., 3:] if rational else h[..., :3]
    try:
        return BSplinePatch(points, (p, q), (U, V), w)
    except GshadeError as exc:
        raise GshadeError(f"{where}: unusable NURBS surface ({exc})") from None


def _homogeneous(c) -> tuple[float, float, float, float]:
    return (c.X, c.Y, c.Z, c.W)


def _kind(surface, scale: float) -> str:
    """The surface type that openNURBS recognises within 1e-9 x the surface's size."""
    tol = max(1e-9 * scale, 1e-12)
    for name, test in (
        ("plane", "IsPlanar"),
        ("sphere", "IsSphere"),
        ("cylinder", "IsCylinder"),
        ("cone", "IsCone"),
        ("torus", "IsTorus"),
    ):
        if getattr(surface, test)(tol):
            return name
    return "bspline"


def _scale(patch: BSplinePatch) -> float:
    P = patch.points.reshape(-1, 3)
    return float(np.ptp(P, axis=0).max()) or 1.0


def _surface_face(path: Path, surface, nurbs, index: int) -> CadFace:
    """A free surface object: one untrimmed face over its whole domain."""
    patch = nurbs_patch(nurbs, f"{path}: object surface {index}")
    (u0, u1), (v0, v1) = patch.domain
    loop = np.array([[u0, v0], [u1, v0], [u1, v1], [u0, v1], [u0, v0]])
    return CadFace(
        index=index,
        kind=_kind(surface, _scale(patch)),
        patch=patch,
        box=patch.domain,
        loops=[loop],
    )


def _brep_face(path: Path, brep, face, index: int) -> CadFace:
    """One Brep face: its NURBS form, the mapped parameter box and the recovered loops."""
    nurbs = face.ToNurbsSurface()
    if nurbs is None:
        raise GshadeError(f"{path}: face {index} has no NURBS form")
    patch = nurbs_patch(nurbs, f"{path}: face {index}")
    (nu0, nu1), (nv0, nv1) = patch.domain
    du, dv = face.Domain(0), face.Domain(1)
    corners = []
    for s in (du.T0, du.T1):
        for t in (dv.T0, dv.T1):
            ok, a, b = face.GetNurbsFormParameterFromSurfaceParameter(s, t)
            if ok:
                corners.append((a, b))
    if corners:
        c = np.array(corners)
        box = (
            (max(nu0, float(c[:, 0].min())), min(nu1, float(c[:, 0].max()))),
            (max(nv0, float(c[:, 1].min())), min(nv1, float(c[:, 1].max()))),
        )
    else:
        box = patch.domain
    single = face.DuplicateFace(False)
    trimmed = not (single is not None and bool(single.IsSurface))
    closed = (bool(nurbs.IsClosed(0)), bool(nurbs.IsClosed(1)))
    loops, tol = _loops(brep, face, _Grid(patch, box, closed))
    return CadFace(
        index=index,
        kind=_kind(face, _scale(patch)),
        patch=patch,
        box=box,
        reversed=bool(face.OrientationIsReversed),
        loops=loops,
        loop_tolerance=tol,
        trimmed=trimmed,
    )


def _loops(brep, face, grid: _Grid) -> tuple[list[NDArray[np.float64]], float]:
    """The face's loops in the NURBS form's (u, v), outer first, and their tolerance."""
    outer: list[NDArray[np.float64]] = []
    inner: list[NDArray[np.float64]] = []
    tol = 0.0
    for loop in face.Loops:
        curves = []
        for trim in loop.Trims:
            k = int(trim.EdgeIndex)
            if k < 0 or k >= len(brep.Edges):
                continue  # singular trim: bridged by its neighbours' end points
            pts = _edge_points(brep.Edges[k])
            curves.append(pts[::-1] if trim.IsReversed else pts)
        if not curves:
            continue
        uv, t = _pull_back(grid, np.concatenate(curves))
        tol = max(tol, t)
        keep = np.r_[True, np.any(np.abs(np.diff(uv, axis=0)) > 1e-12 * grid.span, axis=1)]
        uv = uv[keep]
        uv = np.vstack([uv, uv[:1]])
        (outer if str(loop.LoopType).endswith("Outer") else inner).append(uv)
    return outer + inner, tol


def _edge_points(edge) -> NDArray[np.float64]:
    """Points along an edge curve, both ends included."""
    d = edge.Domain
    n = int(edge.SpanCount) * int(edge.Degree) * _SAMPLES_PER_SPAN
    n = min(max(n, _MIN_SAMPLES), _MAX_SAMPLES)
    ts = np.linspace(d.T0, d.T1, n)
    return np.array([_xyz(edge.PointAt(float(t))) for t in ts])


class _Grid:
    """A patch sampled on a grid over ``box``, for starting points of the inversion."""

    def __init__(self, patch: BSplinePatch, box, closed: tuple[bool, bool]):
        self.patch = patch
        (u0, u1), (v0, v1) = patch.domain
        self.lo = np.array([u0, v0])
        self.hi = np.array([u1, v1])
        self.span = self.hi - self.lo
        self.closed = closed
        gu = np.linspace(box[0][0], box[0][1], _GRID)
        gv = np.linspace(box[1][0], box[1][1], _GRID)
        self.uv = np.stack(np.meshgrid(gu, gv, indexing="ij"), -1).reshape(-1, 2)
        self.xyz = patch(self.uv[:, 0], self.uv[:, 1])
        self.scale = float(np.ptp(self.xyz, axis=0).max()) or 1.0

    def wrap(self, uv: NDArray[np.float64]) -> NDArray[np.float64]:
        """Parameters brought into the domain: across the seam of a closed direction, else
        clipped."""
        out = np.clip(uv, self.lo, self.hi)
        for d in (0, 1):
            if self.closed[d]:
                out[:, d] = self.lo[d] + np.mod(uv[:, d] - self.lo[d], self.span[d])
        return out


def _pull_back(grid: _Grid, xyz: NDArray[np.float64]) -> tuple[NDArray[np.float64], float]:
    """(u, v) of the surface points nearest ``xyz`` (m, 3), in order along a loop.

    Returns the parameters and the loop tolerance: the largest 3D residual over the smallest
    parameter speed there (singular points, where the speed vanishes, are left out).
    """
    d2 = ((xyz[:, None, :] - grid.xyz[None, :, :]) ** 2).sum(-1)
    uv = grid.uv[np.argmin(d2, axis=1)].copy()
    d = grid.patch.derivatives(uv[:, 0], uv[:, 1], 1)
    for _ in range(_NEWTON_STEPS):
        r = d[0, 0] - xyz
        J = np.stack([d[1, 0], d[0, 1]], -1)  # (m, 3, 2)
        A = np.einsum("mki,mkj->mij", J, J)
        g = np.einsum("mki,mk->mi", J, r)
        A += (1e-12 * np.trace(A, axis1=1, axis2=2) + 1e-300)[:, None, None] * np.eye(2)
        step = -np.linalg.solve(A, g[..., None])[..., 0]
        old = (r**2).sum(-1)
        for _halving in range(8):  # backtrack where the step makes things worse
            trial = grid.wrap(uv + step)
            dt = grid.patch.derivatives(trial[:, 0], trial[:, 1], 1)
            worse = ((dt[0, 0] - xyz) ** 2).sum(-1) > old
            if not worse.any():
                break
            step[worse] *= 0.5
        better = ~worse
        uv[better] = trial[better]
        d[:, :, better] = dt[:, :, better]
        if np.all(np.abs(step) <= 1e-14 * grid.span):
            break
    d = grid.patch.derivatives(uv[:, 0], uv[:, 1], 1)
    res = np.linalg.norm(d[0, 0] - xyz, axis=1)
    J = np.stack([d[1, 0], d[0, 1]], -1)
    speed = np.linalg.svd(J, compute_uv=False)[:, -1]
    singular = speed <= 1e-8 * grid.scale
    slow_u = np.linalg.norm(d[1, 0], axis=1) < np.linalg.norm(d[0, 1], axis=1)
    _fix_ambiguous(grid, uv, np.where(singular, np.where(slow_u, 0, 1), -1))
    ratio = res[~singular] / speed[~singular]
    return uv, float(ratio.max()) if ratio.size else 0.0


def _fix_ambiguous(grid: _Grid, uv: NDArray[np.float64], free: NDArray[np.intp]) -> None:
    """Choose, in place, among parameters that name the same point: on the seam of a closed
    direction the end nearer the neighbouring points; at a pole (``free`` >= 0: the direction
    along which the surface does not move) the neighbour's parameter."""
    m = len(uv)
    span = grid.hi - grid.lo
    for d in (0, 1):
        if not grid.closed[d]:
            continue
        seam = (np.abs(uv[:, d] - grid.lo[d]) <= 1e-9 * span[d]) | (
            np.abs(uv[:, d] - grid.hi[d]) <= 1e-9 * span[d]
        )
        for i in _outward(seam):
            near = uv[(i - 1) % m, d] if not seam[(i - 1) % m] else uv[(i + 1) % m, d]
            lo_side = abs(near - grid.lo[d]) < abs(near - grid.hi[d])
            uv[i, d] = grid.lo[d] if lo_side else grid.hi[d]
            seam[i] = False
    pole = free >= 0
    for i in _outward(pole):
        j = (i - 1) % m if not pole[(i - 1) % m] else (i + 1) % m
        uv[i, free[i]] = uv[j, free[i]]
        pole[i] = False


def _outward(mask: NDArray[np.bool_]) -> list[int]:
    """Indices of ``mask`` ordered so that each comes next to one already resolved (none
    when every index is in ``mask``)."""
    m = len(mask)
    mask = mask.copy()
    order: list[int] = []
    while mask.any() and not mask.all():
        ready = [i for i in np.flatnonzero(mask) if not (mask[(i - 1) % m] and mask[(i + 1) % m])]
        if not ready:
            break
        for i in ready:
            mask[i] = False
        order.extend(int(i) for i in ready)
    return order
