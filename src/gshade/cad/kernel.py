"""What the modules that work on the kernel's shapes share: a shape's faces in the kernel's
traversal order, and a kernel exception in a few words."""

from __future__ import annotations

from OCP.TopAbs import TopAbs_FACE
from OCP.TopExp import TopExp_Explorer
from OCP.TopoDS import TopoDS, TopoDS_Shape

__all__ = ["exception_text", "shape_faces"]


def shape_faces(shape: TopoDS_Shape) -> list:
    """The shape's faces in the kernel's traversal order."""
    out = []
    explorer = TopExp_Explorer(shape, TopAbs_FACE)
    while explorer.More():
        out.append(TopoDS.Face(explorer.Current()))
        explorer.Next()
    return out


def exception_text(exc: BaseException) -> str:
    """A kernel (OCP) exception in a few words: its type and its message's first line (they
    often carry no message).

    Examples
    --------
    >>> exception_text(RuntimeError("Standard_Failure\\nmore"))
    'RuntimeError: Standard_Failure'
    >>> exception_text(ValueError())
    'ValueError'
    """
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0]}" if text else type(exc).__name__
