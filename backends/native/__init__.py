"""Native backend: the C++ ray tracer extension (``_native``) and its thin Python wrapper."""

from . import _native

__all__ = ["_native"]
