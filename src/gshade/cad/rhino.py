"""Rhino ``.3dm`` files (openNURBS, through rhino3dm) as exact faces.

Every Brep face, extrusion (as a Brep) and free surface becomes a :class:`CadFace` whose patch
is the surface's own NURBS form.  openNURBS stores one knot fewer at each end than the
textbook vector; the end knots are repeated to pad it (they weigh on no basis function inside
the domain, so periodic, unclamped surfaces come out the same).

The Python bindings expose no 2D trimming curves: each loop is recovered by pulling the 3D
edge curves back into the NURBS form's (u, v) by point inversion
(:mod:`gshade.cad.rhino_inversion`).  Where the surface meets itself
(seams of closed or nearly closed directions, poles) each trim is put on the end that its
loop's sense asks for (:mod:`gshade.cad.rhino_seams`).  Singular trims at poles are the
segment between their neighbours.  The kernel's shape: :mod:`gshade.cad.rhino_brep`.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import rhino3dm
from numpy.typing import NDArray

from ..errors import GshadeError
from ..geometry.patches.bspline import BSplinePatch
from ..io.files import read_bytes
from ..limits import MAX_DATA_FILE_BYTES
from . import rhino_brep as brep
from . import rhino_seams as seams
from . import rhino_trims as tr
from .model import CadFace, CadModel, LeftOutFace, no_usable_face
from .rhino_inversion import Grid, pull_back

__all__ = ["read"]

_MAGIC = b"3D Geometry File Format "

#: openNURBS unit names and their short names.
_UNITS = dict(
    pair.split("=")
    for pair in (
        "Angstroms=angstrom Nanometers=nm Microns=um Millimeters=mm Centimeters=cm "
        "Decimeters=dm Meters=m Dekameters=dam Hectometers=hm Kilometers=km Megameters=Mm "
        "Gigameters=Gm Microinches=uin Mils=mil Inches=in Feet=ft Yards=yd Miles=mi "
        "NauticalMiles=nmi AstronomicalUnits=au LightYears=ly Parsecs=pc PrinterPoints=pt "
        "PrinterPicas=pica"
    ).split()
)


def read(
    path: str | os.PathLike, sew: bool | None = None, tolerance: float | None = None
) -> CadModel:
    """Read a Rhino ``.3dm`` file into exact faces.

    Parameters
    ----------
    path : path-like
    sew, tolerance
        Ignored: the kernel's shape takes the file's own topology (its edges are shared).

    Returns
    -------
    CadModel
        The faces in the order of the objects (Breps, extrusions, surfaces), the model's unit,
        the union of the objects' bounding boxes, and the kernel's shape with those faces.

    Raises
    ------
    GshadeError
        One line naming the file (and face): not a regular readable file, too large, not 3dm,
        unreadable by openNURBS, no surfaces in it (only meshes, curves...), a kernel failure.
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
    left_out: list[LeftOutFace] = []
    parts: list[tr.BrepPart | int] = []
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    number = 0  # the next face's number
    hidden = [0, 0]  # objects and faces Rhino does not draw
    layers_on = _layers_on(model)
    for obj in model.Objects:
        geom: Any = obj.Geometry if obj is not None else None
        if isinstance(geom, rhino3dm.Extrusion):
            geom = geom.ToBrep(False)
        if isinstance(geom, (rhino3dm.Brep, rhino3dm.Surface)) and not _drawn(obj, layers_on):
            hidden[0] += 1
            hidden[1] += len(geom.Faces) if isinstance(geom, rhino3dm.Brep) else 1  # type: ignore[arg-type]
            continue
        before = len(faces)
        if isinstance(geom, rhino3dm.Brep):
            part = tr.BrepPart(geom, {})
            for face in list(geom.Faces):  # type: ignore[call-overload]
                if face is not None:
                    try:
                        cad, trims = _brep_face(path, part, face, number)
                        part.faces.append((number, trims))
                        faces.append(cad)
                    except Exception as exc:  # a bad face costs that face
                        left_out.append(LeftOutFace(number, _said(exc, path), _READING))
                    number += 1
            parts.append(part)
        elif isinstance(geom, rhino3dm.Surface):
            nurbs = geom.ToNurbsSurface()
            if nurbs is not None:
                try:
                    faces.append(_surface_face(path, geom, nurbs, number))
                    parts.append(number)
                except Exception as exc:
                    left_out.append(LeftOutFace(number, _said(exc, path), _READING))
                number += 1
        if geom is not None and len(faces) > before:
            box = geom.GetBoundingBox()
            if box is not None and box.IsValid:
                lo = np.minimum(lo, _xyz(box.Min))
                hi = np.maximum(hi, _xyz(box.Max))
    notes = []
    if hidden[0]:
        notes.append(
            f"{hidden[0]} objects ({hidden[1]} faces) that Rhino does not draw (hidden, on "
            "layers that are off, in block definitions or on layout pages) passed over"
        )
    if not faces:
        if left_out:
            raise no_usable_face(path, left_out)
        raise GshadeError(
            f"{path}: expected surfaces (Breps, extrusions, NURBS), found {tr.found(model)}"
            + (f" ({notes[0]})" if notes else "")
        )
    shape, built, unbuilt = brep.build_brep(path, faces, parts)
    if unbuilt:
        lost = {f.index for f in unbuilt}
        faces = [f for f in faces if f.index not in lost]
        left_out = sorted([*left_out, *unbuilt], key=lambda f: f.index)
        if not faces:
            raise no_usable_face(path, left_out)
    return CadModel(
        path=path,
        faces=faces,
        unit=_unit(model),
        bounds=(lo, hi),
        brep=shape,
        left_out=left_out,
        notes=notes,
        kernel_faces=tuple(built),
    )


#: What was tried on a face the reader leaves out.
_READING = "reading its NURBS surface and recovering its trims"


def _said(exc: BaseException, path: Path) -> str:
    """A reader's error about one face in a few words, without the file's name."""
    if isinstance(exc, GshadeError):
        text = str(exc)
        text = text.removeprefix(f"{path}: ")
        return text.split(": ", 1)[1] if text.startswith("face ") and ": " in text else text
    first = (str(exc).strip().splitlines() or [""])[0][:200]
    return f"the reader failed ({type(exc).__name__}{': ' * bool(first)}{first})"


def _drawn(obj: Any, layers_on: list[bool]) -> bool:
    """Whether Rhino draws the object: visible (not hidden), not part of a block's
    definition (drawn only through its instances), not on a layout page, on a layer that is
    on (``layers_on``: :func:`_layers_on`)."""
    attributes = obj.Attributes
    index = attributes.LayerIndex
    return bool(
        attributes.Visible
        and attributes.Mode
        not in (rhino3dm.ObjectMode.Hidden, rhino3dm.ObjectMode.InstanceDefinitionObject)
        and not attributes.IsInstanceDefinitionObject
        and attributes.ActiveSpace != rhino3dm.ActiveSpace.PageSpace  # type: ignore[attr-defined]
        and (not 0 <= index < len(layers_on) or layers_on[index])
    )


def _layers_on(model: Any) -> list[bool]:
    """Per layer, whether it and all its parent layers are on."""
    layers = list(model.Layers)
    place = {str(layer.Id): k for k, layer in enumerate(layers)}
    on: list[bool] = []
    for layer in layers:
        seen, current, visible = set(), layer, True
        while current is not None and str(current.Id) not in seen:
            seen.add(str(current.Id))
            visible &= bool(current.Visible)
            parent = place.get(str(current.ParentLayerId))
            current = layers[parent] if parent is not None else None
        on.append(visible)
    return on


def _unit(model: Any) -> str:
    """The model's length unit as a short name, or ``"unknown"``."""
    try:
        name = model.Settings.ModelUnitSystem.name
    except AttributeError:
        return "unknown"
    return _UNITS.get(name, "unknown")


def _xyz(p: Any) -> NDArray[np.float64]:
    return np.array([p.X, p.Y, p.Z], dtype=np.float64)


def nurbs_patch(nurbs: Any, where: Path | str = "surface") -> BSplinePatch:
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


def _homogeneous(c: Any) -> tuple[float, float, float, float]:
    return (c.X, c.Y, c.Z, c.W)


def _kind(surface: Any, scale: float) -> str:
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


def _surface_face(path: Path, surface: Any, nurbs: Any, index: int) -> CadFace:
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


def _brep_face(
    path: Path, part: tr.BrepPart, face: Any, index: int
) -> tuple[CadFace, list[list[tr.Trim]]]:
    """One Brep face: its NURBS form, the mapped parameter box, the recovered loops (and
    their trims)."""
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
    closed = seams.closed_directions(nurbs, patch)
    loops, tol, trims = _loops(part, face, Grid(patch, box, closed))
    return CadFace(
        index=index,
        kind=_kind(face, _scale(patch)),
        patch=patch,
        box=tr.trimmed_box(box, loops),
        reversed=bool(face.OrientationIsReversed),
        loops=loops,
        loop_tolerance=tol,
        trimmed=trimmed,
    ), trims


def _loops(
    part: tr.BrepPart, face: Any, grid: Grid
) -> tuple[list[NDArray[np.float64]], float, list[list[tr.Trim]]]:
    """The face's loops in the NURBS form's (u, v), outer first, their tolerance, and the
    loops' trims (each trim's samples at its edge's parameters, for the kernel's shape)."""
    brep, count = part.brep, len(part.brep.Edges)
    chains: list[tuple[bool, list[tr.Trim], NDArray[np.float64]]] = []
    for loop in face.Loops:
        trims: list[tr.Trim] = []
        curves = []
        for trim in loop.Trims:
            k, rev = int(trim.EdgeIndex), bool(trim.IsReversed)
            ends = (int(trim.StartVertexIndex), int(trim.EndVertexIndex))
            if k < 0 or k >= count:  # singular trim: bridged by its neighbours' end points
                trims.append(tr.Trim(-1, rev, ends))
                continue
            if k not in part.samples:
                part.samples[k] = tr.edge_points(brep.Edges[k])
            t, pts = part.samples[k]
            trims.append(tr.Trim(k, rev, ends, t))
            curves.append(pts[::-1] if rev else pts)
        if curves:
            outer = str(loop.LoopType).endswith("Outer")
            chains.append((outer, trims, np.concatenate(curves)))
    if not chains:
        return [], 0.0, []
    # all the loops of the face in one batch, with each point's neighbours along its loop
    sizes = np.array([len(c) for _, _, c in chains])
    first = np.repeat(np.cumsum(sizes) - sizes, sizes)
    size = np.repeat(sizes, sizes)
    local = np.arange(len(first)) - first
    near = np.stack([first + (local - 1) % size, first + (local + 1) % size])
    uv_all, ratio_all, free_all = pull_back(grid, np.concatenate([c for *_, c in chains]), near)
    cuts = np.cumsum(sizes)[:-1]
    outer_loops: list[NDArray[np.float64]] = []
    inner_loops: list[NDArray[np.float64]] = []
    outer_trims: list[list[tr.Trim]] = []
    inner_trims: list[list[tr.Trim]] = []
    tol = 0.0
    for (is_outer, trims, _), uv, ratio, free in zip(
        chains,
        np.split(uv_all, cuts),
        np.split(ratio_all, cuts),
        np.split(free_all, cuts),
        strict=True,
    ):
        seams.fix_ambiguous(grid, uv, free, is_outer, [len(t.t) for t in trims if t.edge >= 0])
        tr.split_trims(trims, uv, free)
        ratio = ratio[free < 0]
        tol = max(tol, float(ratio.max()) if ratio.size else 0.0)
        keep = np.r_[True, np.any(np.abs(np.diff(uv, axis=0)) > 1e-12 * grid.span, axis=1)]
        uv = uv[keep]
        uv = np.vstack([uv, uv[:1]])
        (outer_loops if is_outer else inner_loops).append(uv)
        (outer_trims if is_outer else inner_trims).append(trims)
    return outer_loops + inner_loops, tol, outer_trims + inner_trims
