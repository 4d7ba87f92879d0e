"""Cameras: frozen look-at pinhole and orthographic cameras."""

from incandescent.camera.camera import Camera, default_camera
from incandescent.camera.rig import Rig

__all__ = ["Camera", "Rig", "default_camera"]
