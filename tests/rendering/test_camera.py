"""Framing: the automatic camera shows every surface point, tightly; explicit cameras look
where they are told; pixel rays agree with a pinhole projection written out here."""

import numpy as np
import pytest

from gshade import GshadeError
from gshade.rendering.camera import AUTO_DIRECTION, MARGIN, frame_view
from gshade.scene import Camera


def blob(seed=0, n=400):
    """Points of an irregular, off-centre cloud (a surface's samples stand-in)."""
    rng = np.random.default_rng(seed)
    return rng.normal(size=(n, 3)) * [3.0, 1.0, 0.5] + [10.0, -4.0, 2.0]


def project(view, points):
    """Normalised image coordinates in [-1, 1] (x to the right, y up) by the pinhole model."""
    rel = points - view.origin
    x, y, z = rel @ view.right, rel @ view.true_up, rel @ view.forward
    aspect = view.image_width / view.image_height
    if view.type == "orthographic":
        half = view.width / 2
        return x / half, y * aspect / half
    tan_h = np.tan(np.radians(view.fov) / 2)
    return x / (z * tan_h), y * aspect / (z * tan_h)


@pytest.mark.parametrize("kind", ["perspective", "orthographic"])
@pytest.mark.parametrize(("width", "height"), [(320, 240), (240, 320), (100, 100)])
def test_automatic_framing_shows_every_point_with_the_margin(kind, width, height):
    points = blob()
    view = frame_view(Camera(kind, None, None, (0, 0, 1), 30.0, None), points, width, height)
    x, y = project(view, points)
    extent = max(np.abs(x).max(), np.abs(y).max())
    assert extent <= 1 / MARGIN + 1e-9  # everything inside, with the margin
    # and no farther away than needed (in perspective: before the eye turns to centre them)
    assert extent >= (1 / MARGIN - 1e-6) * (0.8 if kind == "perspective" else 1.0)


def test_the_automatic_view_is_centred_in_the_picture():
    points = blob(1)
    ortho = frame_view(Camera("orthographic", None, None, (0, 0, 1), 30.0, None), points, 400, 300)
    x, y = project(ortho, points)
    assert abs(x.max() + x.min()) < 1e-9 and abs(y.max() + y.min()) < 1e-9  # exactly
    for seed, (width, height) in ((1, (400, 300)), (2, (300, 400)), (3, (200, 200))):
        points = blob(seed) * [1.0, 6.0, 1.0]  # long along the depth: perspective matters
        camera = Camera("perspective", None, None, (0, 0, 1), 30.0, None)
        x, y = project(frame_view(camera, points, width, height), points)
        assert abs(x.max() + x.min()) < 1e-6 and abs(y.max() + y.min()) < 1e-6  # centred
        assert max(np.abs(x).max(), np.abs(y).max()) <= 1 / MARGIN  # within the margin


def test_an_explicit_camera_looks_where_it_is_told():
    camera = Camera("perspective", (1.0, 2.0, 3.0), (4.0, 6.0, 3.0), (0, 0, 1), 45.0, None)
    view = frame_view(camera, blob(), 200, 100)
    assert np.allclose(view.origin, [1, 2, 3]) and np.allclose(view.forward, [0.6, 0.8, 0.0])
    assert np.allclose(view.true_up, [0, 0, 1])
    x, y = project(view, np.array([[4.0, 6.0, 3.0]]))
    assert np.allclose([x[0], y[0]], 0.0)  # the target sits at the image centre


@pytest.mark.parametrize("kind", ["perspective", "orthographic"])
def test_pixel_rays_pass_through_the_points_they_project_to(kind):
    points = blob(2, 50)
    view = frame_view(Camera(kind, None, None, (0, 0, 1), 40.0, None), points, 64, 48)
    x, y = project(view, points)
    # the fractional pixel each point projects to, as (row, col) of a pixel's centre
    cols = (x + 1) / 2 * view.image_width - 0.5
    rows = (1 - y) / 2 * view.image_height - 0.5
    origins, directions = view.pixel_rays(rows, cols)
    rel = points - origins
    miss = np.linalg.norm(rel - (rel * directions).sum(1)[:, None] * directions, axis=1)
    assert np.all(miss <= 1e-9 * np.linalg.norm(rel, axis=1))


@pytest.mark.parametrize(
    ("origin", "target", "up", "message"),
    [
        ((1, 1, 1), (1, 1, 1), (0, 0, 1), r"^target: expected a point other than origin, got "),
        (
            (0, 0, 5),
            (0, 0, 0),
            (0, 0, 1),
            r"^up: expected a direction not parallel to target - origin \[0.0, 0.0, -5.0\], "
            r"got \[0, 0, 1\]$",
        ),
        ((0, 0, 5), (0, 0, 0), (0, 1e-12, -3), "^up: expected a direction not parallel"),
        (None, None, (0, 0, 0), r"^up: expected a direction \[x, y, z\] of length at least 1e-12"),
        (None, None, (9e-13, 0, 0), "^up: expected a direction .* at least 1e-12"),
        ((0, 0), None, (0, 0, 1), r"^origin: expected 3 finite numbers \[x, y, z\], got \[0, 0\]"),
        (None, (0, 0, np.nan), (0, 0, 1), "^target: expected 3 finite numbers"),
        (None, None, "up", "^up: expected 3 finite numbers"),
    ],
)
def test_impossible_cameras_cannot_be_made(origin, target, up, message):
    """The camera's vectors are checked where a Camera is made (a scene file's too)."""
    with pytest.raises(GshadeError, match=message) as info:
        Camera("perspective", origin, target, up, 30.0, None)
    assert "\n" not in str(info.value)


def test_a_camera_keeps_its_vectors_as_floats():
    camera = Camera("perspective", [1, 2, 3], np.array([4, 6, 3]), (0, 0, 1), 45.0, None)
    assert camera.origin == (1.0, 2.0, 3.0) and camera.target == (4.0, 6.0, 3.0)
    assert all(type(c) is float for v in (camera.origin, camera.target, camera.up) for c in v)


def test_a_view_the_camera_chose_is_checked_as_a_given_one():
    points = blob()
    centre = (points.min(axis=0) + points.max(axis=0)) / 2
    # the eye at the centre of the surfaces: the automatic target is the origin
    at_centre = Camera("perspective", tuple(centre), None, (0, 0, 1), 30.0, None)
    with pytest.raises(
        GshadeError,
        match=r"^\[camera\] \(target automatic: the centre of the surfaces\) target: expected a "
        r"point other than origin",
    ):
        frame_view(at_centre, points, 8, 8)
    # above the centre, looking down along up
    above = Camera("perspective", tuple(centre + np.array([0, 0, 5])), None, (0, 0, 1), 30.0, None)
    with pytest.raises(
        GshadeError,
        match=r"^\[camera\] \(target automatic.*\) up: expected a direction not parallel",
    ):
        frame_view(above, points, 8, 8)
    # up along the automatic view direction (once a view of NaNs)
    for target in (None, (0, 0, 0)):
        along = Camera("perspective", None, target, tuple(AUTO_DIRECTION), 30.0, None)
        with pytest.raises(
            GshadeError,
            match=r"^\[camera\] \(origin automatic\) up: expected a direction not parallel",
        ):
            frame_view(along, points, 8, 8)
