"""Exact shape-function values at the pixel centres (issue 14, point 2): ``f`` is the
function at the point P, N, u, v describe, ``f.mean`` the samples' mean the colour shows,
``f2`` the colour-mapped function of ``display = "both"``, ``render.aovs`` extra functions,
all against closed forms at P."""

from __future__ import annotations

import numpy as np
import pytest

from gshade.app.cli import main
from gshade.errors import GshadeError
from gshade.io import read_exr
from gshade.rendering import render
from gshade.scene import parse_scene

RENDER = '[render]\nwidth = 120\nheight = 90\nspp = 4\nlighting = "flat"\n'
CAMERA = "[camera]\norigin = [4, -5, 3.5]\ntarget = [0, 0, 0.3]\nup = [0, 0, 1]\nfov = 50\n"


def _scene_text(surface: str, shape: str = "", aovs=("mean", "gaussian")) -> str:
    names = ", ".join(f'"{n}"' for n in aovs)
    return f"[[surface]]\n{surface}\n[shape]\n{shape}\n{RENDER}aovs = [{names}]\n{CAMERA}"


def _render(surface: str, shape: str, aovs=("mean", "gaussian")):
    return render(parse_scene(_scene_text(surface, shape, aovs)))


def _hits(image):
    on = image["patch"] >= 0
    P = np.stack([image[f"P.{c}"] for c in "XYZ"], -1).astype(np.float64)
    return on, P


def test_sphere_torus_cylinder_at_every_pixel_centre():
    """H and K at every hit pixel equal the closed forms at its P to 1e-6 relative:
    sphere 1/R and 1/R^2; cylinder 1/(2R) and 0; torus with rho = |P_xy|, cos v =
    (rho - R)/r: K = cos v / (r rho), H = (R + 2 r cos v) / (2 r rho)."""
    cases = {
        'type = "sphere"\nradius = 1.5': lambda P: (1 / 1.5, 1 / 1.5**2),
        'type = "cylinder"\nradius = 0.8\nheight = 1.2': lambda P: (1 / 1.6, 0.0 * P[:, 0]),
        'type = "torus"\nmajor = 2.0\nminor = 0.6': None,
    }
    for surface, closed in cases.items():
        image = _render(surface, 'function = "mean"\ndisplay = "colormap"')
        on, P = _hits(image)
        assert on.sum() > 500
        H, K = image["mean"][on].astype(np.float64), image["gaussian"][on].astype(np.float64)
        if closed is None:
            rho = np.hypot(P[on][:, 0], P[on][:, 1])
            cos_v = (rho - 2.0) / 0.6
            K_exact = cos_v / (0.6 * rho)
            H_exact = (2.0 + 2 * 0.6 * cos_v) / (2 * 0.6 * rho)
        else:
            H_exact, K_exact = closed(P[on])
        scale = np.max(np.abs(H_exact))
        assert np.abs(np.abs(H) - np.abs(H_exact)).max() < 1e-6 * scale, surface
        assert np.abs(K - K_exact).max() < 1e-6 * scale**2, surface
        # f is the mean curvature at the same point; f.mean the samples' mean
        assert np.array_equal(image["f"][on], image["mean"][on])
        assert "f.mean" in image.channels


def test_f_is_the_value_at_p_and_f_mean_what_the_colour_shows():
    """Planar sections (f = <P, n>) on the sphere: f at every hit is <P, n> exactly (to
    float32), while f.mean, over the jittered samples, differs by up to the slope times the
    sample spread."""
    image = _render('type = "sphere"', 'function = "planar_sections"\ndirection = [0, 0, 1]')
    on, P = _hits(image)
    assert np.abs(image["f"][on] - P[on][:, 2]).max() < 1e-6
    assert np.abs(image["f.mean"][on] - P[on][:, 2]).max() > 1e-4


def test_display_both_writes_the_colour_function_as_f2():
    image = _render(
        'type = "sphere"',
        'function = "isophotes"\ndisplay = "both"\ncolour_function = "gaussian"',
        aovs=(),
    )
    on, _ = _hits(image)
    assert np.allclose(image["f2"][on], 1.0, rtol=1e-6)  # K = 1 on the unit sphere
    assert not np.allclose(image["f"][on], 1.0)


def test_aovs_from_the_command_line_and_bad_names(tmp_path, capsys):
    scene = tmp_path / "s.toml"
    scene.write_text(f'[[surface]]\ntype = "sphere"\n{RENDER}{CAMERA}')
    out = tmp_path / "s.exr"
    assert main(["render", str(scene), "-o", str(out), "--aovs", "gaussian,max_principal"]) == 0
    channels, _ = read_exr(out)
    assert {"gaussian", "max_principal", "f", "f.mean"} <= set(channels)
    assert main(["render", str(scene), "-o", str(tmp_path / "t.exr"), "--aovs", "gausian"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "aovs" in err and "gaussian" in err
    assert not (tmp_path / "t.exr").exists()
    with pytest.raises(GshadeError, match="aovs: expected each name once"):
        parse_scene(_scene_text('type = "sphere"', aovs=("mean", "mean")))
