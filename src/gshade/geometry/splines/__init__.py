"""Geometric splines and junctions (Kiciak, ch. 3 and 4): the piecewise cubic bases of β- and
γ-splines, ν-splines, and patches joined with prescribed G^k continuity."""
