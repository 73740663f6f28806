"""gshade's Mitsuba plugins, registered for a variant in one place: :func:`use_variant`.

The shape integrator (:mod:`gshade.rendering.integrator`) and the sensor of listed pixels
(:mod:`gshade.rendering.pixel_sensor`) are Python classes put on Mitsuba's active variant
(:func:`variant_class`) and registered under their names (:data:`PLUGINS`).  Mitsuba keeps
such a plugin for the variant that was active when it was registered and cannot be asked
whether a name is registered (``PluginManager.plugin_type`` knows only its own plugins), so
the variants done in this process are kept here, in :data:`REGISTERED`.  The pipeline calls
:func:`use_variant` where it selects the variant; nothing is registered by importing gshade.
"""

from __future__ import annotations

from typing import Any

from ..runtime.backend import drjit_ops
from ..runtime.llvm import import_drjit
from ..runtime.variant import mitsuba, select_variant
from .integrator import SHAPE_PLUGIN, ShapeIntegrator
from .pixel_sensor import PIXELS_PLUGIN, PixelSensor

__all__ = ["PLUGINS", "REGISTERED", "use_variant", "variant_class"]

#: plugin name -> (Mitsuba's registering function, the plugin's methods, its Mitsuba base)
PLUGINS: dict[str, tuple[str, type, str]] = {
    SHAPE_PLUGIN: ("register_integrator", ShapeIntegrator, "SamplingIntegrator"),
    PIXELS_PLUGIN: ("register_sensor", PixelSensor, "Sensor"),
}
#: the variants whose plugins are registered with Mitsuba in this process
REGISTERED: set[str] = set()

#: what every Python class has of its own, not copied onto the variant's class
_CLASS_INTERNALS = ("__dict__", "__weakref__")


def variant_class(methods: type, base: str, mi: Any) -> type:
    """A plugin's class for Mitsuba's active variant ``mi``: a subclass of the variant's
    ``base`` (e.g. ``"SamplingIntegrator"``) with the attributes of ``methods`` and the
    variant's parts as class attributes: ``mi`` (the Mitsuba module), ``dr`` (Dr.Jit),
    ``ops`` (:func:`gshade.runtime.backend.drjit_ops`) and ``scalar`` (whether the variant
    runs one sample at a time).

    Mitsuba's classes take one base (nanobind), so ``methods`` is copied, not inherited
    (with the attributes of its own Python bases, e.g. the shape integrator's
    :class:`gshade.rendering.reflection_sampling.ReflectionSampling`); its methods call no
    ``super()``.
    """
    scalar = mi.variant().startswith("scalar")
    parts = {"mi": mi, "dr": import_drjit(), "ops": drjit_ops(scalar), "scalar": scalar}
    own: dict[str, Any] = {}
    for klass in reversed(methods.__mro__[:-1]):  # its bases' attributes first (not object's)
        own.update({k: v for k, v in vars(klass).items() if k not in _CLASS_INTERNALS})
    return type(methods.__name__, (getattr(mi, base),), own | parts)


def use_variant(requested: str = "auto") -> str:
    """Make ``requested`` Mitsuba's active variant
    (:func:`gshade.runtime.variant.select_variant`) and register gshade's plugins for it, the
    first time that variant is used; the variant's name."""
    variant = select_variant(requested)
    if variant not in REGISTERED:
        mi = mitsuba()
        for name, (register, methods, base) in PLUGINS.items():
            cls = variant_class(methods, base, mi)
            getattr(mi, register)(name, lambda props, cls=cls: cls(props))
        REGISTERED.add(variant)
    return variant
