"""Scene texts shared by the render tests."""

SPHERE = """
name = "sphere"
[[surface]]
type = "sphere"
radius = 1.0
[shape]
function = "isophotes"
light = [0, -1, 0]
display = "stripes"
period = 0.125
[camera]
type = "orthographic"
origin = [0, -5, 0]
target = [0, 0, 0]
up = [0, 0, 1]
width = 2.2
[render]
width = 512
height = 512
spp = 4
lighting = "flat"
"""
