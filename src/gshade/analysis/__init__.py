"""Analysis of a surface's patches: the junctions between them (continuity classes and their
measures, Kiciak §2) and the junction lines drawn over a rendered picture."""
