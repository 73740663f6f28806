"""n-sided holes of a Catmull–Clark surface filled with G1 / G2 Bézier patches (Kiciak, ch. 5):
the hole and its ring, the quadratic energies, the filling, the filled surface, and the
fairing functionals lowered on the surface itself (with their cache)."""
