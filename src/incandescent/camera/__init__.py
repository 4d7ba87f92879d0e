"""Cameras: frozen look-at pinhole and orthographic cameras."""

from incandescent.camera.camera import Camera, default_camera

__all__ = ["Camera", "default_camera"]
