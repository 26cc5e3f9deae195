"""The marker every extension point's base class carries.

A config's ``_target_`` may name only a class that derives from :class:`ExtensionPoint`
(:mod:`mcpilco.safe_config`). Each concept's base class (a system, a kernel, a cost, ...)
derives from it directly, so the list of extension points is the set of its direct
subclasses and this module, the lowest of the library, knows none of them by name.
"""

from __future__ import annotations


class ExtensionPoint:
    """Marker base class of the classes a config may build (no state, no methods)."""

    __slots__ = ()


def extension_points() -> tuple[type, ...]:
    """The base classes that derive from :class:`ExtensionPoint` directly (one per
    concept), among the modules imported so far, sorted by their dotted names."""
    return tuple(
        sorted(ExtensionPoint.__subclasses__(), key=lambda c: f"{c.__module__}.{c.__qualname__}")
    )
