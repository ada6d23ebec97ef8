"""Documents loaded one after another (F12 after F12, a view's edits) -> what of the last load holds again: a
material or an object whose part of the document is the same as before is the same built value, and a whole
document the same as before is the same Scene, whose pickle the workers know (they keep what they prepared for it).

Loading 3,000 separate cubes' materials and objects costs the loader about 0.15 s an F12; comparing their parts with
the last document's about 0.025 s, most of it in C (lists of numbers compared as lists)."""

from __future__ import annotations

from typing import Any

import numpy as np

from . import scene as sc

_SCALARS = (int, float, str, bool, type(None))


def same(a: Any, b: Any) -> bool:
    """Whether two parsed documents (or parts) load to the same thing: equal dicts, lists and scalars of the same
    types (1 and 1.0 differ, and NaN is never the same, so either is loaded again), and NumPy arrays of the same
    dtype, shape and values. Lists of numbers, or of lists of numbers, are compared in C, where 1 == 1.0: a number in
    such a list that changes its type alone is not loaded again (the engine's export writes the same types each
    time; a fresh load would refuse a float among triangle indices)."""
    if a is b:
        return True
    kind = type(a)
    if kind is not type(b):
        return False
    if kind is dict:
        if a.keys() != b.keys():
            return False
        return all(same(value, b[key]) for key, value in a.items())
    if kind is list or kind is tuple:
        if len(a) != len(b):
            return False
        if a and _plain(a[0]) and _plain(b[0]):
            try:
                return bool(a == b)
            except ValueError:  # an array further in (not an export's document): compared item by item
                pass
        return all(same(x, y) for x, y in zip(a, b, strict=True))
    if kind is np.ndarray:
        return a.dtype == b.dtype and a.shape == b.shape and bool(np.array_equal(a, b))
    return bool(a == b)


def _plain(value: Any) -> bool:
    """A number (or string), or a list that starts with one: what Python's own == compares as the loader reads it."""
    kind = type(value)
    return kind in _SCALARS or (kind is list and (not value or type(value[0]) in _SCALARS))


def _file_named(body: Any) -> bool:
    """Whether a material reads an image by a file's path (the file may have changed under the same name)."""
    if not isinstance(body, dict):
        return False
    return any(isinstance(texture, dict) and "image" in texture for texture in (body.get(key) for key in _TEXTURES))


_TEXTURES = ("texture", "emission_texture")


class LoadedParts:
    """The last document that loaded without a problem, its Scene, and its materials and objects as built, for
    scene_from_dict(..., kept=this) to use again where their parts are the same. Only a load that succeeds replaces
    them: a part is used again only if it loaded, and was checked, before."""

    def __init__(self) -> None:
        self.document: dict | None = None
        self.scene: sc.Scene | None = None
        self._materials: dict[str, tuple[Any, sc.Material]] = {}
        self._objects: list[tuple[Any, sc.SceneObject | None]] = []
        self._object_context: tuple[Any, Any] | None = None  # what objects are checked against: names, meshes
        self.reused = 0  # materials and objects used again in the last load (for tests and measurements)

    def clear(self) -> None:
        self.__init__()

    def whole(self, document: Any) -> sc.Scene | None:
        """The last Scene, where document is the same as the last one's."""
        if self.scene is not None and same(document, self.document) and not self._reads_files():
            self.reused = len(self._materials) + len(self._objects)
            return self.scene
        return None

    def _reads_files(self) -> bool:
        background = self.document.get("background") if isinstance(self.document, dict) else None
        return _file_named({"texture": background}) or any(_file_named(body) for body, _ in self._materials.values())

    def material(self, name: str, body: Any) -> sc.Material | None:
        """The material built last time for this name and body, or None."""
        kept = self._materials.get(name)
        if kept is None or _file_named(body) or not same(body, kept[0]):
            return None
        self.reused += 1
        return kept[1]

    def objects_usable(self, material_names: Any, meshes: Any) -> bool:
        """Whether last time's objects were checked against the same materials' names and the same meshes table."""
        return self._object_context is not None and same((sorted(material_names), meshes), self._object_context)

    def object(self, index: int, body: Any) -> sc.SceneObject | None:
        """The object built last time at this index from the same body, or None."""
        if index >= len(self._objects):
            return None
        kept_body, built = self._objects[index]
        if built is None or not same(body, kept_body):
            return None
        self.reused += 1
        return built

    def remember(
        self,
        document: dict,
        scene: sc.Scene,
        materials: dict[str, tuple[Any, sc.Material]],
        objects: list[tuple[Any, sc.SceneObject | None]],
        object_context: tuple[Any, Any],
    ) -> None:
        self.document, self.scene = document, scene
        self._materials, self._objects, self._object_context = materials, objects, object_context
