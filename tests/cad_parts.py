"""Parts built with the CAD kernel at test time, shared by the CAD tests (never outside files)."""

from __future__ import annotations

import pytest

pytest.importorskip("OCP")

from OCP.BRepFilletAPI import BRepFilletAPI_MakeFillet
from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
from OCP.TopAbs import TopAbs_EDGE
from OCP.TopExp import TopExp_Explorer
from OCP.TopoDS import TopoDS

#: The box's sides and the fillet radius of :func:`filleted_box`.
BOX_SIZE = (10.0, 20.0, 30.0)
FILLET_RADIUS = 2.0


def filleted_box(size=BOX_SIZE, r: float = FILLET_RADIUS):
    """A box with all 12 edges filleted at r: 6 planes, 12 exact cylinders, 8 sphere corners."""
    box = BRepPrimAPI_MakeBox(*size).Shape()
    fillet = BRepFilletAPI_MakeFillet(box)
    explorer = TopExp_Explorer(box, TopAbs_EDGE)
    while explorer.More():
        fillet.Add(r, TopoDS.Edge(explorer.Current()))
        explorer.Next()
    return fillet.Shape()
