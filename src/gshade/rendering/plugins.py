"""gshade's Mitsuba plugins, registered for a variant in one place: :func:`use_variant`.

The shape integrator (:mod:`gshade.rendering.integrator`) and the sensor of listed pixels
(:mod:`gshade.rendering.pixel_sensor`) are Python classes defined for Mitsuba's active variant
and registered under their names (:data:`PLUGINS`).  Mitsuba keeps such a plugin for the
variant that was active when it was registered and cannot be asked whether a name is
registered (``PluginManager.plugin_type`` knows only its own plugins), so the variants done
in this process are kept here, in :data:`REGISTERED`.  The pipeline calls :func:`use_variant`
where it selects the variant; nothing is registered by importing gshade.
"""

from __future__ import annotations

from collections.abc import Callable

from ..runtime.variant import mitsuba, select_variant
from .integrator import SHAPE_PLUGIN, shape_integrator_class
from .pixel_sensor import PIXELS_PLUGIN, pixel_sensor_class

__all__ = ["PLUGINS", "REGISTERED", "use_variant"]

#: plugin name -> (Mitsuba's registering function, the plugin's class for the active variant)
PLUGINS: dict[str, tuple[str, Callable]] = {
    SHAPE_PLUGIN: ("register_integrator", shape_integrator_class),
    PIXELS_PLUGIN: ("register_sensor", pixel_sensor_class),
}
#: the variants whose plugins are registered with Mitsuba in this process
REGISTERED: set[str] = set()


def use_variant(requested: str = "auto") -> str:
    """Make ``requested`` Mitsuba's active variant
    (:func:`gshade.runtime.variant.select_variant`) and register gshade's plugins for it, the
    first time that variant is used; the variant's name."""
    variant = select_variant(requested)
    if variant not in REGISTERED:
        mi = mitsuba()
        for name, (register, plugin_class) in PLUGINS.items():
            cls = plugin_class(mi)
            getattr(mi, register)(name, lambda props, cls=cls: cls(props))
        REGISTERED.add(variant)
    return variant
