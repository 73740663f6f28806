"""Cameras: explicit or framed automatically around the surfaces, as Mitsuba sensors.

Perspective cameras take the horizontal field of view (degrees); orthographic ones the view
width in scene units.  Without origin and target the camera looks at the centre of the
bounding box from a three-quarter view above it, at the distance where the bounding sphere
fills the narrower image side (with a margin); in perspective the eye is then turned until
the surfaces' projection is centred in the picture.  :func:`fit_view` then fits a resolved view
tightly on the surfaces (for figures: the projected extent fills the image up to a margin).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import GshadeError
from ..scene import validate_view
from ..scene.model import Camera
from ..scene.tables import reported

__all__ = ["View", "fit_view", "frame_view", "header_view"]

#: Default viewing direction for automatic framing (from the target toward the eye).
AUTO_DIRECTION = np.array([0.55, -0.75, 0.45])
MARGIN = 1.08
#: What a message about a view the camera chose says first.
_AUTOMATIC_ORIGIN = "[camera] (origin automatic) "
_AUTOMATIC_TARGET = "[camera] (target automatic: the centre of the surfaces) "


@dataclass(frozen=True)
class View:
    """A resolved camera: where it is, where it looks, and its projection."""

    type: str
    origin: NDArray
    target: NDArray
    up: NDArray
    fov: float
    width: float | None
    image_width: int
    image_height: int

    @property
    def forward(self) -> NDArray:
        d = self.target - self.origin
        return d / np.linalg.norm(d)

    @property
    def right(self) -> NDArray:
        r = np.cross(self.forward, self.up)
        return r / np.linalg.norm(r)

    @property
    def true_up(self) -> NDArray:
        return np.cross(self.right, self.forward)

    @property
    def view_width(self) -> float:
        """The width in scene units that an orthographic view spans (:func:`frame_view`
        always sets it for one)."""
        if self.width is None:
            raise GshadeError("[camera] width: an orthographic view needs one")
        return self.width

    def pixel_size(self, distance: float) -> float:
        """World size of one pixel at the given distance along the view direction."""
        if self.type == "orthographic":
            return self.view_width / self.image_width
        return 2.0 * distance * np.tan(np.radians(self.fov) / 2) / self.image_width

    def pixel_rays(self, rows: NDArray, cols: NDArray) -> tuple[NDArray, NDArray]:
        """Origins and unit directions (N, 3) of the rays through pixel centres (row 0 at the
        top), as Mitsuba's sensors cast them."""
        x = (2.0 * (cols + 0.5) / self.image_width - 1.0)[:, None]
        y = (1.0 - 2.0 * (rows + 0.5) / self.image_height)[:, None]
        aspect = self.image_width / self.image_height
        if self.type == "orthographic":
            half = self.view_width / 2
            origin = self.origin + half * (x * self.right + y / aspect * self.true_up)
            return origin, np.broadcast_to(self.forward, origin.shape)
        tan_h = np.tan(np.radians(self.fov) / 2)
        d = self.forward + tan_h * (x * self.right + y / aspect * self.true_up)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        return np.broadcast_to(self.origin, d.shape), d

    def camera_coordinates(self, points: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        """Coordinates of points (N, 3) along the view's right, up and forward axes, from
        the eye."""
        rel = points - self.origin
        return rel @ self.right, rel @ self.true_up, rel @ self.forward

    def image_positions(self, x: NDArray, y: NDArray, z: NDArray) -> tuple[NDArray, NDArray]:
        """Continuous image positions (column, row; pixel k spans [k, k + 1]) of camera
        coordinates: the inverse of :meth:`pixel_rays` (z > 0 for a perspective view)."""
        W, H = self.image_width, self.image_height
        aspect = W / H
        if self.type == "orthographic":
            half = self.view_width / 2
            sx, sy = x / half, y / half * aspect
        else:
            tan_h = np.tan(np.radians(self.fov) / 2)
            with np.errstate(divide="ignore", invalid="ignore"):
                sx, sy = x / (z * tan_h), y / (z * tan_h) * aspect
        return (sx + 1.0) * W / 2, (1.0 - sy) * H / 2

    def key_light(self) -> tuple[float, float, float]:
        """A light from above and left of the camera, toward the scene."""
        d = 0.6 * self.true_up - 0.45 * self.right - 0.65 * self.forward
        x, y, z = (float(c) for c in d / np.linalg.norm(d))
        return x, y, z

    def sensor(self, mi: Any, spp: int, seed: int, sampler: str = "jittered") -> dict:
        """The Mitsuba sensor dict with a box filter and a stratified sampler: jittered
        (``'jittered'``), at the strata centres (``'symmetric'``), or one sample at each
        pixel centre (``'centre'``)."""
        T = mi.ScalarTransform4f
        to_world = T().look_at(
            origin=self.origin.tolist(), target=self.target.tolist(), up=self.up.tolist()
        )
        span = float(np.linalg.norm(self.target - self.origin))
        sensor = {
            "near_clip": max(span * 1e-4, 1e-6),
            "far_clip": span * 1e3 + 1.0,
            "film": {
                "type": "hdrfilm",
                "width": self.image_width,
                "height": self.image_height,
                "rfilter": {"type": "box"},
                "pixel_format": "rgba",
            },
        }
        if sampler == "centre":
            sensor["sampler"] = {"type": "stratified", "sample_count": 1, "jitter": False}
        elif sampler == "symmetric":
            # strata centres: symmetric about the pixel centre, so that the mean over the
            # samples of a quantity linear across the pixel is its value at the centre
            sensor["sampler"] = {"type": "stratified", "sample_count": spp, "jitter": False}
        else:
            sensor["sampler"] = {"type": "stratified", "sample_count": spp, "seed": seed}
        if self.type == "orthographic":
            half = self.view_width / 2
            sensor.update(type="orthographic", to_world=to_world @ T().scale([half, half, 1.0]))
        else:
            sensor.update(type="perspective", to_world=to_world, fov=self.fov, fov_axis="x")
        return sensor


def _centre_in_view(points: NDArray, up: NDArray) -> NDArray:
    """The point to aim at so that the surfaces sit centred in the automatic view: the centre
    of their extent across the view (and the box centre along it)."""
    direction = AUTO_DIRECTION / np.linalg.norm(AUTO_DIRECTION)
    right = np.cross(-direction, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, -direction)
    centre = (points.min(axis=0) + points.max(axis=0)) / 2
    rel = points - centre
    x, y = rel @ right, rel @ true_up
    return centre + right * (x.max() + x.min()) / 2 + true_up * (y.max() + y.min()) / 2


def frame_view(camera: Camera, points: NDArray, width: int, height: int) -> View:
    """Resolve a scene's camera (a :class:`gshade.scene.Camera`: its vectors are valid) for
    surface points (N, 3) sampled densely enough to stand for the surfaces' extent.  The
    view is checked as the Camera checks given vectors (:func:`gshade.scene.validate_view`)
    where it chose the origin or the target."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre = (lo + hi) / 2
    radius = max(float(np.linalg.norm(hi - lo)) / 2, 1e-9)
    up = np.asarray(camera.up, dtype=np.float64)
    aspect = width / height
    direction = AUTO_DIRECTION / np.linalg.norm(AUTO_DIRECTION)
    if camera.origin is None:  # the automatic eye looks along -direction
        with reported(_AUTOMATIC_ORIGIN):
            validate_view(direction, np.zeros(3), up)
    target = centre if camera.target is None else np.asarray(camera.target, dtype=np.float64)
    if camera.target is None and camera.origin is None:
        target = _centre_in_view(points, up)
    if camera.origin is None:
        forward = -direction
        right = np.cross(forward, up)
        right /= np.linalg.norm(right)
        true_up = np.cross(right, forward)
        rel = points - target
        x, y, z = rel @ right, rel @ true_up, rel @ forward
        if camera.type == "orthographic":
            distance = 2.0 * radius
        else:
            # the nearest distance at which every point lies inside the frustum
            tan_h = np.tan(np.radians(camera.fov) / 2)
            tan_v = tan_h / aspect
            distance = float(
                max(
                    np.max(MARGIN * np.abs(x) / tan_h - z),
                    np.max(MARGIN * np.abs(y) / tan_v - z),
                    radius * 1e-3,
                )
            )
        origin = target + distance * direction
    else:
        origin = np.asarray(camera.origin, dtype=np.float64)
    if camera.origin is None or camera.target is None:
        with reported(_AUTOMATIC_ORIGIN if camera.origin is None else _AUTOMATIC_TARGET):
            validate_view(origin, target, up)
    forward = (target - origin) / np.linalg.norm(target - origin)
    view_width = camera.width
    if camera.type == "orthographic" and view_width is None:
        right = np.cross(forward, up)
        right /= np.linalg.norm(right)
        true_up = np.cross(right, forward)
        rel = points - target
        half_w = np.max(np.abs(rel @ right))
        half_h = np.max(np.abs(rel @ true_up))
        view_width = 2 * MARGIN * max(half_w, half_h * aspect)
    view = View(camera.type, origin, target, up, float(camera.fov), view_width, width, height)
    if camera.type == "perspective" and camera.origin is None and camera.target is None:
        view = _centred(view, points)
    return view


def _centred(view: View, points: NDArray) -> View:
    """An automatic perspective view turned about its eye until the points' projection is
    centred (:func:`_aimed`): the near side of the surfaces projects larger, so the extent
    centred across the view (:func:`_centre_in_view`) sits off the picture's centre.  The
    eye stays at the automatic distance, so the points stay within the margin."""
    aimed = _aimed(view, points)[0]
    target = view.origin + aimed.forward * float(np.linalg.norm(view.target - view.origin))
    with reported(_AUTOMATIC_TARGET):
        validate_view(view.origin, target, view.up)
    return replace(view, target=target)


#: Re-aiming steps of :func:`fit_view` (each centres the projected extent better; a few do).
_FIT_STEPS = 60


def fit_view(view: View, points: NDArray, margin: float) -> View:
    """The view fitted tightly on surface points (N, 3): their projected bounding box fills
    the image up to ``margin`` (a fraction of the image's width and height on each side)
    on one axis and lies centred within it on the other.

    Parameters
    ----------
    view : View
        A resolved view (:func:`frame_view`): its type, eye, up and image size are kept.
    points : ndarray, shape (N, 3)
        Points standing for the surfaces' extent (sampled densely enough).
    margin : float
        In [0, 0.5): the empty fraction of the image on each side of the extent.

    Returns
    -------
    View
        Perspective: the same eye, turned toward the centre of the extent (in the image
        plane), with the horizontal field of view that fits it; the picture is the view's
        own, enlarged (a crop rendered at full resolution).  Orthographic: the same
        direction, moved across the view onto the extent's centre, with the view width that
        fits it.

    Raises
    ------
    GshadeError
        ``margin: ...`` out of range; ``points: ...`` when a perspective eye has surface
        points beside or behind it (no field of view below 180 degrees shows them).
    """
    if not 0.0 <= margin < 0.5:
        raise GshadeError(f"margin: expected a number in [0, 0.5), got {margin!r}")
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    aspect = view.image_width / view.image_height
    fill = 1.0 - 2.0 * margin  # the fraction of the image the extent spans
    if view.type == "orthographic":
        x, y, _ = view.camera_coordinates(points)
        shift = view.right * (x.max() + x.min()) / 2 + view.true_up * (y.max() + y.min()) / 2
        width = max(float(np.ptp(x)), float(np.ptp(y)) * aspect, 1e-12) / fill
        return replace(view, origin=view.origin + shift, target=view.target + shift, width=width)
    fitted, sx, sy, z = _aimed(view, points)
    half = max(float(np.ptp(sx)), float(np.ptp(sy)) * aspect) / 2
    fov = float(np.degrees(2.0 * np.arctan(max(half, 1e-12) / fill)))
    if not fov < 179.0:
        raise GshadeError(
            f"points: a perspective view from this eye needs a field of view of {fov:.4g} "
            "degrees to show the surfaces (expected below 179)"
        )
    target = view.origin + fitted.forward * float(np.median(z))
    with reported(_AUTOMATIC_TARGET):
        validate_view(view.origin, target, view.up)
    return replace(view, target=target, fov=fov)


def _aimed(view: View, points: NDArray) -> tuple[View, NDArray, NDArray, NDArray]:
    """A perspective view turned about its eye until the points' projected bounding box is
    centred in the image (a few re-aiming steps), with the points' image-plane coordinates
    x / z, y / z and depths z (the view's target one unit ahead of the eye)."""
    eye, forward = view.origin, view.forward
    for step in range(_FIT_STEPS + 1):
        fitted = replace(view, target=eye + forward)
        x, y, z = fitted.camera_coordinates(points)
        if not np.all(z > 1e-9 * max(float(np.max(np.abs(z))), 1e-300)):
            raise GshadeError(
                "points: the camera's eye has surfaces beside or behind it; a perspective "
                "view fitted on them would need a field of view of 180 degrees or more"
            )
        sx, sy = x / z, y / z  # the image plane at distance 1
        cx, cy = (sx.max() + sx.min()) / 2, (sy.max() + sy.min()) / 2
        half = max(float(np.ptp(sx)), float(np.ptp(sy)))
        if max(abs(cx), abs(cy)) <= 1e-12 * max(half, 1e-300) or step == _FIT_STEPS:
            break
        forward = forward + cx * fitted.right + cy * fitted.true_up
        forward /= np.linalg.norm(forward)
    return fitted, sx, sy, z


def header_view(metadata: dict[str, Any], width: int, height: int) -> View:
    """The view a render was made with, from its header's ``settings`` (the camera as
    rendered), for a picture of ``width`` x ``height`` pixels."""
    import json

    camera = json.loads(str(metadata["settings"]))["camera"]
    return View(
        camera["type"],
        np.array(camera["origin"]),
        np.array(camera["target"]),
        np.array(camera["up"]),
        camera["fov"],
        camera["width"],
        width,
        height,
    )
