"""Scene files in, linear float images out: the documented Whitted Phong / Blinn-Phong ray tracer in NumPy.

No Blender import anywhere in this package: it runs in any Python 3.11 with NumPy, and inside Blender.
"""

from .scene.loader import SceneError, default_scene, load_scene, scene_from_dict
from .workers.parallel import Renderer, RenderResult, render

__all__ = ["RenderResult", "Renderer", "SceneError", "default_scene", "load_scene", "render", "scene_from_dict"]
