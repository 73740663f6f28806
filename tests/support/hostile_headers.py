"""Malformed EXR header attributes (the hostile reproducers' cases, and more), for the
header and view-page tests."""

import json

#: The attribute of reproducer 02 and 09.
BAD_JUNCTIONS = '{"colours": [1, 2, 3], "junctions": []}'


def shape_settings(**shape) -> str:
    return json.dumps({"shape": {"function": "mean", "display": "colormap", **shape}})


#: Reproducer 01's cases (and more): attribute -> the malformed value.
HOSTILE = {
    "junctions-colours-list": ("junctions", BAD_JUNCTIONS),
    "junctions-colours-str": ("junctions", '{"colours": "red", "junctions": []}'),
    "junctions-colour-text": ("junctions", '{"colours": {"G1": ["a", 0, 0]}, "junctions": []}'),
    "junctions-colour-class": ("junctions", '{"colours": {"__proto__": [1, 0, 0]}}'),
    "junctions-list-int": ("junctions", '{"junctions": 5}'),
    "junctions-not-object": ("junctions", "[1, 2]"),
    "junctions-not-json": ("junctions", "{junctions"),
    "junctions-deep": ("junctions", '{"junctions": ' + "[" * 100000 + "]" * 100000 + "}"),
    "junctions-nine-deep": ("junctions", '{"junctions": ' + "[" * 9 + "]" * 9 + "}"),
    "junctions-patch-1e19": ("junctions", '{"junctions": [{"class": "G1", "patches": [0, 1e19]}]}'),
    "junctions-patch-2e31": (
        "junctions",
        json.dumps({"junctions": [{"class": "G1", "patches": [0, 2**31]}]}),
    ),
    "junctions-patch-negative": (
        "junctions",
        json.dumps({"junctions": [{"class": "G1", "patches": [-1, 2]}]}),
    ),
    "junctions-patch-float": (
        "junctions",
        json.dumps({"junctions": [{"class": "G1", "patches": [0.5, 2]}]}),
    ),
    "junctions-no-class": ("junctions", json.dumps({"junctions": [{"patches": [0, 1]}]})),
    "junctions-class-markup": (
        "junctions",
        json.dumps({"junctions": [{"class": "<b>G1</b>", "patches": [0, 1]}]}),
    ),
    "junctions-sides": (
        "junctions",
        json.dumps({"junctions": [{"class": "G1", "patches": [0, 1], "sides": ["u0"]}]}),
    ),
    "junctions-measure": (
        "junctions",
        json.dumps({"junctions": [{"class": "G1", "patches": [0, 1], "gap": [1]}]}),
    ),
    "junctions-huge-int": ("junctions", '{"junctions": [' + "1" * 5000 + "]}"),
    "junctions-overflow": ("junctions", '{"junctions": [1e400]}'),
    "junctions-string-long": ("junctions", json.dumps({"junctions": ["x" * 5000]})),
    "settings-shape-str": ("settings", '{"shape": "x"}'),
    "settings-shape-list": ("settings", '{"shape": [1, 2]}'),
    "settings-render-list": ("settings", '{"render": [1, 2]}'),
    "settings-deep": ("settings", '{"shape": ' + "[" * 100000 + "]" * 100000 + "}"),
    "settings-range-str": ("settings", shape_settings(range=["abc", 1])),
    "settings-range-null": ("settings", shape_settings(range=[None, 1])),
    "settings-range-list": ("settings", shape_settings(range=[[1], [2]])),
    "settings-range-empty": ("settings", shape_settings(value_range=[1, 1])),
    "settings-range-inf": (
        "settings",
        '{"shape": {"function": "mean", "display": "colormap", "range": [-Infinity, Infinity]}}',
    ),
    "settings-range-nan": (
        "settings",
        '{"shape": {"function": "mean", "display": "colormap", "range": [NaN, 1]}}',
    ),
    "settings-function-number": ("settings", shape_settings(function=3)),
    "settings-width-text": ("settings", '{"render": {"width": "160"}}'),
    "settings-not-text": ("settings", 5),
    "settings-too-long": ("settings", json.dumps({"shape": {"x": ["y" * 4000] * 300}})),
    "scene-name-number": ("scene_name", 12),
    "legend-too-long": ("legend", "x" * 5000),
}
