"""Patch kinds with exact derivatives: Bézier, B-spline and NURBS, bicubically blended Coons
patches and surfaces of revolution (Kiciak, ch. 2)."""
