"""The shared core of the geometry: the patch protocol (:class:`~gshade.geometry.core.patch.Patch`),
Bernstein bases, knot vectors, rational derivatives, differential geometry (fundamental
forms, curvatures, unit normals) and first-order jets."""
