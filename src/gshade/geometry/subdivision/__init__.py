"""Catmull–Clark subdivision surfaces: quad meshes, the regular patches and refinement, and
Stam's exact patches at extraordinary vertices."""
