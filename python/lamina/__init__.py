"""Lamina's Python client: the wire declarations (`lamina.wire`) and a small client API
(`lamina.Core`) over the official iceoryx2 package."""

from . import wire
from .client import Core, Feedback, LaminaError, NodeFrame

__all__ = ["wire", "Core", "Feedback", "LaminaError", "NodeFrame"]
