"""The scene model: frozen dataclasses in Blender's world conventions.

Z is up, lengths are metres, rotations are Euler XYZ angles in degrees (as Blender's UI shows them), colors are
linear RGB in [0, 1]. Every object has a location, a rotation, a size of its own kind and the name of a material.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass, field, fields, replace
from operator import attrgetter
from typing import Literal

import numpy as np

from .motion import Motion

Vec3 = tuple[float, float, float]
Color = tuple[float, float, float]
Pose = tuple[Vec3, Vec3]  # (location in metres, rotation as Euler XYZ degrees): where an object is at one time

MODELS = ("phong", "blinn-phong")
BACKGROUNDS = ("solid", "sky", "documented", "none", "image")
AREA_SHAPES = ("square", "rectangle", "disk", "ellipse")
BACKGROUND_INTERPOLATIONS = ("linear", "closest")
SENSOR_FITS = ("AUTO", "HORIZONTAL", "VERTICAL")
CAMERA_TYPES = ("PERSP", "ORTHO", "PANO")
PANORAMA_TYPES = ("EQUIRECTANGULAR", "FISHEYE_EQUIDISTANT", "FISHEYE_EQUISOLID", "MIRRORBALL")
DTYPES = ("float32", "float64")
NUMERICS = ("documented", "robust")
FALLOFFS = ("none", "inverse_square")
SPOT_MODELS = ("cycles4", "cycles3")
DISC_MODELS = ("cycles4", "cycles3")  # a sun's disc as Cycles 4.0+ or Cycles 3.x shows it (emitters.py)
WHITE = (1.0, 1.0, 1.0)
BLACK = (0.0, 0.0, 0.0)
# straight-through (alpha) continuations along one path, as Cycles' Transparent Max Bounces (default 8): a ray that
# would pass a ninth partly transparent surface ends there (black, and opaque to the film's alpha); a shadow ray is
# blocked by it (docs/algorithm.md, "Glass and transparency")
TRANSPARENT_BOUNCES = 8
# the data passes (depth, mist, normal, position, indices, Cryptomatte) show the first surface a camera ray meets
# straight on with alpha at least this (Cycles' View Layer > Passes > Alpha Threshold, default 0.5)
PASS_ALPHA_THRESHOLD = 0.5


@dataclass(frozen=True)
class Material:
    """Surface response of the documented model.

    specular: the Phong exponent s (Blinn-Phong uses s * coef); 0 means matte, no specular term at all.
    reflective: r in [0, 1]; the local color is weighted by 1 - r and the mirror ray by r.
    emission (>= 0): added to the local color, neither shadowed nor weighted by 1 - r (mirror rays see it too).
    two_sided: a hit on the back of a surface (geometric N.D > 0) shades with the flipped normals.
    specular_color: None, the documented rule (the whole intensity multiplies color); else the specular terms
    multiply this color and the ambient and diffuse terms multiply color.
    transmission: t in [0, 1], the share of the surface that is a clear dielectric of index ior (> 0; outside is
    air): Fresnel-weighted mirror and refracted rays (the refracted tinted by color); its shadow is opaque.
    alpha: a in [0, 1], coverage: 1 - a of every ray (camera, mirror, refracted, shadow) passes straight through.
    The defaults (t = 0, a = 1) are the documented model (docs/algorithm.md, "Glass and transparency").
    glossy: the colour of a rough specular lobe added to the local colour (GGX microfacets of Cycles' roughness;
    render.glossy_samples reflection rays per hit): glossy_fresnel "constant" (the colour at every angle, Cycles'
    Glossy BSDF) or "schlick" (the colour at normal incidence, white at grazing: a Principled metal);
    glossy_energy "multiscatter" (Cycles' Multiscatter GGX: the energy single scattering loses added back) or
    "single"; glossy_source "traced" (the lights through the lobe and its reflection rays) or "world" (the
    background along the lobe's sampled directions, unshadowed and untraced: a dielectric's few percent, whose
    lights the documented highlight already has). The default (black) is the documented model (docs/algorithm.md,
    "Glossy reflection").
    """

    color: Color = (0.8, 0.8, 0.8)
    specular: float = 0.0
    reflective: float = 0.0
    emission: Color = BLACK
    two_sided: bool = False
    specular_color: Color | None = None
    pass_index: int = 0  # Blender's Material > Settings > Pass Index: the Material Index pass's value
    # an image by the hit's UVs (meshes with uvs): its sample replaces color (texture) or emission
    # (emission_texture) at the hit; color and emission stay the values of hits without UVs
    texture: Texture | None = None
    emission_texture: Texture | None = None
    transmission: float = 0.0
    ior: float = 1.45
    alpha: float = 1.0
    glossy: Color = BLACK
    roughness: float = 0.5
    glossy_fresnel: Literal["constant", "schlick"] = "constant"
    glossy_energy: Literal["multiscatter", "single"] = "multiscatter"
    glossy_source: Literal["traced", "world"] = "traced"
    # Smith's masking-shadowing of the glossy lobe and rough glass: "correlated" (height-correlated, Cycles 4.0 and
    # later) or "separable" (G1 G1, Cycles 3.x)
    glossy_shadowing: Literal["correlated", "separable"] = "correlated"
    # rough glass: the roughness (Cycles') of the glass share's reflection and refraction, sampled by microfacets
    # (transmission_distribution) at render.glossy_samples pairs; 0: the documented sharp glass
    transmission_roughness: float = 0.0
    # rough glass's microfacet distribution: "ggx" (sampled by visible normals, Heitz 2018) or "beckmann" (Cycles'
    # Beckmann: visible normals by Jakob's inversion, Smith's shadowing by Walter et al. 2007's rational G1)
    transmission_distribution: Literal["ggx", "beckmann"] = "ggx"

    @property
    def is_glossy(self) -> bool:
        """Whether the surface has a rough specular lobe (glossy not black)."""
        return self.glossy != BLACK

    @property
    def traces_glossy(self) -> bool:
        """Whether its glossy lobe sends reflection rays (and takes the lights): glossy_source "traced"."""
        return self.is_glossy and self.glossy_source == "traced"

    @property
    def see_through(self) -> bool:
        """Whether rays go on through the surface (refracted or straight): transmission > 0 or alpha < 1."""
        return self.transmission > 0.0 or self.alpha < 1.0


@dataclass(frozen=True, kw_only=True)
class Primitive:
    name: str
    material: str
    location: Vec3 = (0.0, 0.0, 0.0)
    rotation: Vec3 = (0.0, 0.0, 0.0)
    # which rays see the object (Blender's ray visibility), and a holdout (a hole in the image: colour and alpha 0)
    visible_camera: bool = True
    visible_shadow: bool = True
    visible_reflection: bool = True
    holdout: bool = False
    pass_index: int = 0  # Blender's Object > Relations > Pass Index: the Object Index pass's value
    # motion blur: the object's (location, rotation) at evenly spaced times over the shutter, open to close, each in
    # place of location and rotation in its time slice (tracer/frames/shutter.py); () for an object that stays put
    poses: tuple[Pose, ...] = ()


@dataclass(frozen=True, kw_only=True)
class Sphere(Primitive):
    radius: float = 1.0


@dataclass(frozen=True, kw_only=True)
class Plane(Primitive):
    """The plane through location with normal = local +Z; infinite, or a size_x by size_y rectangle."""

    size: tuple[float, float] | None = None


@dataclass(frozen=True, kw_only=True)
class Cylinder(Primitive):
    """A capped cylinder centred on location, its axis along local +Z (as Blender's cylinder primitive)."""

    radius: float = 1.0
    height: float = 2.0


@dataclass(frozen=True, kw_only=True)
class Box(Primitive):
    """A box centred on location with full dimensions size = (x, y, z); 12 triangles."""

    size: Vec3 = (2.0, 2.0, 2.0)


@dataclass(frozen=True, kw_only=True)
class Pyramid(Primitive):
    """A four-sided pyramid: base size[0] by size[1] at local z = -size[2]/2, apex at z = +size[2]/2; 6 triangles."""

    size: Vec3 = (1.0, 1.0, 1.0)


def frozen_array(values: object, dtype: type, shape: tuple[int, ...]) -> np.ndarray:
    """values as a read-only C-contiguous array of dtype and shape (one -1 allowed). An array that is already so,
    and whose memory no writeable array can change (the loader's, or a mesh's passed on by dataclasses.replace), is
    kept without a copy; anything else is copied, so that no caller's array can change a scene once it is made."""
    array = values if isinstance(values, np.ndarray) else np.asarray(values, dtype=dtype)
    if not (array.dtype == dtype and array.flags.c_contiguous and immutable(array)):
        array = np.array(array, dtype=dtype, order="C", copy=True)
    if array.size == 0:  # an empty mesh (a scene made in code): its other axes still hold
        array = np.zeros(tuple(0 if n == -1 else n for n in shape), dtype=dtype)
    if array.ndim != len(shape) or any(n not in (-1, m) for n, m in zip(shape, array.shape, strict=True)):
        array = array.reshape(shape)  # a view of a copy made above, or of an immutable array
    array.flags.writeable = False
    return array


def immutable(array: np.ndarray) -> bool:
    """Whether nothing can write into the array's memory: it and every array it views are read-only, down to one
    that owns its memory."""
    while isinstance(array, np.ndarray):
        if array.flags.writeable:
            return False
        if array.base is None:
            return True
        array = array.base
    return False  # memory of another kind (a mapping, a buffer): someone may hold it writeable


def same_arrays(a: np.ndarray | None, b: np.ndarray | None) -> bool:
    """Whether two of a mesh's arrays hold the same bits (None only equals None): the same shape, dtype and bytes,
    so that 0.0 and -0.0 differ (they can trace differently) where == on floats would call them equal."""
    if a is b:
        return True
    if a is None or b is None or a.shape != b.shape or a.dtype != b.dtype:
        return False
    ARRAY_COMPARISONS[0] += 1
    return bool(np.array_equal(a.reshape(-1).view(np.uint8), b.reshape(-1).view(np.uint8)))


# how many times two arrays were compared bit by bit (same_arrays past its shortcuts): a cache that finds its
# entries by digest compares only on a match, so tests can count this instead of timing a cache
ARRAY_COMPARISONS = [0]


def _add_array(digest, array: np.ndarray | None) -> None:
    """An array's dtype, shape and bits into a running digest (None: a mark of its own)."""
    if array is None:
        digest.update(b"None;")
        return
    contiguous = np.ascontiguousarray(array)
    digest.update(f"{contiguous.dtype.str}{contiguous.shape};".encode())
    digest.update(contiguous.reshape(-1).view(np.uint8).data)


class ArraysByBits:
    """For a frozen dataclass (eq=False) whose ARRAYS fields are NumPy arrays or None: equal where its other fields
    are equal and its arrays hold the same bits (same_arrays; == on arrays is elementwise, which a dataclass's ==
    cannot use). The hash takes a digest of the arrays' contents, computed once per object and kept: objects of one
    shape (every instance of a mesh placed as world triangles) fall in different buckets, so a dict of many of them
    compares arrays only where the digests match, never each against every other. UNCOMPARED fields (made from the
    others) take part in neither."""

    ARRAYS: tuple[str, ...] = ()
    UNCOMPARED: tuple[str, ...] = ()

    def _plain(self) -> tuple:
        """The other fields' values, in their order (a getter made once per class: dataclasses.fields() on each
        call cost half of hashing a scene's 3,000 objects, which a worker does for every new scene)."""
        getter = _PLAIN_GETTERS.get(self.__class__)
        if getter is None:
            left_out = self.ARRAYS + self.UNCOMPARED
            names = [f.name for f in fields(self) if f.name not in left_out]
            many = attrgetter(*names) if names else (lambda _: ())
            getter = _PLAIN_GETTERS[self.__class__] = many if len(names) != 1 else (lambda value: (many(value),))
        return getter(self)

    def contents_digest(self) -> bytes:
        """A 16-byte digest of the ARRAYS' shapes, dtypes and bits (equal arrays, equal digests), in one pass over
        them; computed on first use and kept (the arrays are read-only)."""
        kept = self.__dict__.get("_contents_digest")
        if kept is None:
            digest = hashlib.blake2b(digest_size=16)
            for name in self.ARRAYS:
                _add_array(digest, getattr(self, name))
            kept = digest.digest()
            object.__setattr__(self, "_contents_digest", kept)
        return kept

    def __eq__(self, other: object) -> bool:
        if other.__class__ is not self.__class__:
            return NotImplemented
        if self is other:
            return True
        return (
            self._plain() == other._plain()
            and self.contents_digest() == other.contents_digest()
            and all(same_arrays(getattr(self, name), getattr(other, name)) for name in self.ARRAYS)
        )

    def __hash__(self) -> int:
        """Computed on first use and kept, as the digest (the object is frozen, its fields too)."""
        kept = self.__dict__.get("_hash")
        if kept is None:
            kept = hash((self._plain(), self.contents_digest()))
            object.__setattr__(self, "_hash", kept)
        return kept

    def __getstate__(self) -> dict:
        """Pickled without the kept digest and hash (a worker computes its own where it needs them: a str's hash
        differs from process to process)."""
        state = dict(self.__dict__)
        state.pop("_contents_digest", None)
        state.pop("_hash", None)
        return state


_PLAIN_GETTERS: dict[type, Callable[[object], tuple]] = {}  # ArraysByBits._plain's, by class


INTERPOLATIONS = ("linear", "closest")  # Blender's Image Texture interpolation Linear, Closest
EXTENSIONS = ("repeat", "extend", "clip")  # Blender's REPEAT, EXTEND, CLIP
TEXTURE_KINDS = ("image", "checker", "gradient")  # Image Texture, Checker Texture, Gradient Texture (+ Color Ramp)
# Blender's Gradient Texture types (Cycles' svm_gradient), in the scene format's spelling
GRADIENTS = ("linear", "quadratic", "easing", "diagonal", "radial", "quadratic_sphere", "spherical")
RAMP_INTERPOLATIONS = ("linear", "constant")  # a Color Ramp's Linear and Constant (RGB mode)


@dataclass(frozen=True, kw_only=True, eq=False)
class Texture(ArraysByBits):
    """An image looked up by a mesh's UVs (Blender's Image Texture node): pixels (H, W, 3) float32 linear RGB, row 0
    the image's top (v = 1), column 0 its left (u = 0). interpolation: linear (bilinear between the four nearest
    texel centres, as Cycles) or closest; extension: repeat, extend (the edge texels continue) or clip (texels
    outside the image are black). source: where the pixels came from (a file's path, or "" for pixels given inline), for
    messages and exports only. Equality compares the pixels' bits (ArraysByBits).

    kind "attribute" is a mesh's corner colours (Blender's Color Attribute node), interpolated over each triangle as
    Cycles interpolates them, then gain * colour + bias per channel, clamped to [0, 1] (the nodes after it: a Mix with
    a constant colour, the material's factors); a mesh without colours keeps the material's colour.
    kind "checker" and "gradient" are procedural (Blender's Checker and Gradient Texture nodes on the UV map) and have
    no pixels: colors are the checker's (color1, color2) or the gradient's colour ramp stops' colours (at positions,
    ascending in [0, 1], interpolated by ramp: linear or constant); scale multiplies the checker's UV; gradient is the
    Gradient Texture's type (GRADIENTS). uv_scale, uv_offset: the UV the texture reads is (u su + ou, v sv + ov)
    (Blender's Mapping node), turned by uv_rotation degrees between the scale and the offset (the Mapping's Z
    rotation)."""

    ARRAYS = ("pixels",)

    pixels: np.ndarray = field(default_factory=lambda: np.zeros((1, 1, 3), dtype=np.float32))
    interpolation: Literal["linear", "closest"] = "linear"
    extension: Literal["repeat", "extend", "clip"] = "repeat"
    source: str = ""
    kind: Literal["image", "checker", "gradient", "attribute"] = "image"
    colors: tuple[Vec3, ...] = ()
    positions: tuple[float, ...] = ()
    ramp: Literal["linear", "constant"] = "linear"
    scale: float = 1.0
    gradient: str = "linear"
    # a Mapping node before the texture (every kind): the UV read as (u su + ou, v sv + ov)
    uv_scale: tuple[float, float] = (1.0, 1.0)
    uv_offset: tuple[float, float] = (0.0, 0.0)
    uv_rotation: float = 0.0  # degrees about the UV origin, after uv_scale and before uv_offset (a Mapping's Z)
    gain: Vec3 = (1.0, 1.0, 1.0)  # kind "attribute": gain * colour + bias
    bias: Vec3 = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "pixels", frozen_array(self.pixels, np.float32, (-1, -1, 3)))

    def __setstate__(self, state: dict) -> None:
        for value in state.values():
            if isinstance(value, np.ndarray):
                value.flags.writeable = False
        self.__dict__.update(state)


@dataclass(frozen=True, kw_only=True, eq=False)
class TriangleMesh(ArraysByBits, Primitive):
    """Triangles in local coordinates (vertices and index triples), counter-clockwise seen from outside.

    vertices (V, 3) float64 and triangles (T, 3) int64, read-only arrays (given as arrays or nested sequences: they
    are converted once, here). normals: None (flat) or per triangle its three corner normals (local frame), (T, 3,
    3) float64 (given as three triples or flat x0, y0, z0, x1, ..., z2 per triangle): the shading normal is their
    barycentric interpolation, normalised. materials, material_indices: None (every triangle uses material) or the
    names of the mesh's materials and each triangle's index into them, (T,) int64.

    A million-triangle mesh as tuples of Python floats took 226 MB per process and seconds to make, transform and
    pickle; as arrays it is 36 MB and goes to the kernels without a conversion. Equality compares the arrays' bits
    (ArraysByBits)."""

    ARRAYS = ("vertices", "triangles", "normals", "material_indices", "uvs", "colors")

    vertices: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    triangles: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), dtype=np.int64))
    normals: np.ndarray | None = None
    materials: tuple[str, ...] | None = None
    material_indices: np.ndarray | None = None
    uvs: np.ndarray | None = None  # (T, 3, 2) float64: each triangle's corners' (u, v), for textures
    colors: np.ndarray | None = None  # (T, 3, 3) float64: each triangle's corners' linear RGB, for attribute textures

    def __post_init__(self) -> None:
        set_field = object.__setattr__  # frozen: the conversion happens once, before anyone sees the object
        set_field(self, "vertices", frozen_array(self.vertices, np.float64, (-1, 3)))
        set_field(self, "triangles", frozen_array(self.triangles, np.int64, (-1, 3)))
        if self.normals is not None:
            set_field(self, "normals", frozen_array(self.normals, np.float64, (-1, 3, 3)))
        if self.materials is not None:
            set_field(self, "materials", tuple(self.materials))
        if self.material_indices is not None:
            set_field(self, "material_indices", frozen_array(self.material_indices, np.int64, (-1,)))
        if self.uvs is not None:
            set_field(self, "uvs", frozen_array(self.uvs, np.float64, (-1, 3, 2)))
        if self.colors is not None:
            set_field(self, "colors", frozen_array(self.colors, np.float64, (-1, 3, 3)))

    def __setstate__(self, state: dict) -> None:
        """Unpickled (a worker's copy): the arrays read-only again, as made (pickle does not keep the flag)."""
        for value in state.values():
            if isinstance(value, np.ndarray):
                value.flags.writeable = False
        self.__dict__.update(state)


@dataclass(frozen=True, kw_only=True, eq=False)
class MeshInstances(ArraysByBits, Primitive):
    """One mesh placed many times (Blender's instances: collection, vertex/face, particle and Geometry Nodes ones).

    mesh: the shared TriangleMesh (its own location and rotation unused: its vertices are in the instances' local
    space), named mesh_name in the scene's meshes table. matrices (K, 3, 4) float64: instance k's local-to-world
    affine map, world = M[k, :, :3] @ local + M[k, :, 3] (any invertible matrix: rotated, mirrored, non-uniformly
    scaled), applied before the object's own location and rotation (identity unless a vane turns the group).
    material: every triangle's material where override is true; else the mesh's own (its material, or its
    materials by triangle). The tracer prepares the mesh once and the instances as boxes above it, so an instance
    costs its matrix, not its triangles."""

    ARRAYS = ("matrices",)
    UNCOMPARED = ("mesh",)  # compared below, by its own bits (its digest found once)

    mesh: TriangleMesh
    mesh_name: str = "mesh"
    matrices: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 4)))
    override: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "matrices", frozen_array(self.matrices, np.float64, (-1, 3, 4)))

    def _plain(self) -> tuple:
        return (*super()._plain(), self.mesh)

    @property
    def materials(self) -> tuple[str, ...] | None:
        """The names each triangle's material_indices point into (None: one material for every triangle)."""
        return None if self.override else self.mesh.materials

    @property
    def material_indices(self) -> np.ndarray | None:
        return None if self.override else self.mesh.material_indices

    @property
    def normals(self) -> np.ndarray | None:
        """The mesh's corner normals (T, 3, 3) in its local space, or None (flat)."""
        return self.mesh.normals

    @property
    def uvs(self) -> np.ndarray | None:
        """The mesh's corner UVs (T, 3, 2), or None."""
        return self.mesh.uvs

    @property
    def colors(self) -> np.ndarray | None:
        """The mesh's corner colours (T, 3, 3), or None."""
        return self.mesh.colors

    def __setstate__(self, state: dict) -> None:
        for value in state.values():
            if isinstance(value, np.ndarray):
                value.flags.writeable = False
        self.__dict__.update(state)


def matrix_from_transform(location: Vec3, rotation: Vec3, scale: Vec3) -> np.ndarray:
    """Blender's location, XYZ Euler rotation (degrees) and scale -> the (3, 4) matrix [R @ S | location]."""
    x, y, z = (np.radians(angle) for angle in rotation)
    cx, sx, cy, sy, cz, sz = np.cos(x), np.sin(x), np.cos(y), np.sin(y), np.cos(z), np.sin(z)
    turn = np.array(
        [
            [cy * cz, sx * sy * cz - cx * sz, cx * sy * cz + sx * sz],
            [cy * sz, sx * sy * sz + cx * cz, cx * sy * sz - sx * cz],
            [-sy, sx * cy, cx * cy],
        ]
    )
    return np.concatenate((turn * np.asarray(scale, dtype=np.float64)[None, :], np.reshape(location, (3, 1))), axis=1)


SceneObject = Sphere | Plane | Cylinder | Box | Pyramid | TriangleMesh | MeshInstances


@dataclass(frozen=True)
class AmbientLight:
    intensity: float = 0.2
    color: Color = WHITE  # every light's contribution is multiplied by its color, channel by channel


@dataclass(frozen=True)
class WorldLight:
    """The world as a light that objects shadow (beyond the documented model; Cycles' world light with no
    bounces): a point's diffuse term is the mean of the world's radiance over the unblocked directions of its
    hemisphere, weighted by their cosine, estimated over `samples` directions (a Fibonacci spiral over the
    hemisphere, the same at every point, as a light of a size's samples are). The radiance along a direction:
    intensity times color, times the background's colour along it where radiance is "background" (a picture, a
    sky). No highlight."""

    intensity: float = 1.0
    color: Color = WHITE
    samples: int = 16  # directions over the hemisphere (lightsamples.hemisphere_directions)
    radiance: Literal["background", "color"] = "background"


@dataclass(frozen=True)
class PointLight:
    """falloff inverse_square: the diffuse and specular terms are divided by |L|^2 (L = location - P)."""

    location: Vec3 = (0.0, 0.0, 5.0)
    intensity: float = 0.6
    color: Color = WHITE
    falloff: Literal["none", "inverse_square"] = "none"
    # Blender's light radius (metres): with render.shadow_samples > 1 its shadow rays go to points on the disk of
    # this radius that faces each shaded point, each carrying intensity / samples (soft shadows)
    radius: float = 0.0
    visible_diffuse: bool = True  # Blender's ray visibility (Object > Visibility), as a spot's
    visible_glossy: bool = True
    visible_transmission: bool = True


@dataclass(frozen=True)
class DirectionalLight:
    """direction points from the surface toward the light, as in the seed; its length is kept, as the seed does."""

    direction: Vec3 = (0.0, 0.0, 1.0)
    intensity: float = 0.2
    color: Color = WHITE
    # the sun's angular diameter in degrees (Blender's sun angle): with render.shadow_samples > 1 its shadow rays
    # go to directions spread over that disk of the sky (soft shadows), each carrying intensity / samples
    angle: float = 0.0
    # mirror and refracted rays that meet nothing and point into the disc see its radiance (tracing/emitters.py), as
    # Cycles' reflections show the sun; False: the documented model (the sun is seen only in highlights)
    seen_in_mirrors: bool = False
    # the disc's radiance: cycles4 (Blender 4.0+) i / sin^2(angle / 2) all over it; cycles3 (Blender 3.x) i /
    # (tan^2(angle / 2) cos^3 theta), theta the angle from its centre
    disc_model: Literal["cycles4", "cycles3"] = "cycles4"
    visible_diffuse: bool = True  # Blender's ray visibility (Object > Visibility), as a spot's
    visible_glossy: bool = True
    visible_transmission: bool = True


@dataclass(frozen=True)
class SpotLight:
    """A point light whose terms are multiplied by Cycles' spot attenuation (docs/scene-format.md).

    direction: the cone's axis, from the light outward; spot_size: the full cone angle in degrees; spot_blend: the
    soft edge (0..1); spot_model: cycles4 (Blender 4.x, 5.0: smoothstep only) or cycles3 (Blender 3.4: smoothstep times
    the cosine of the angle to the axis); cone_scale: the cone stretched along x_axis (the light's local X) and the
    axis across it by these factors (Blender 4+: the light object's x and y scales over its z scale), (1, 1) round."""

    location: Vec3 = (0.0, 0.0, 5.0)
    direction: Vec3 = (0.0, 0.0, -1.0)
    intensity: float = 0.6
    color: Color = WHITE
    falloff: Literal["none", "inverse_square"] = "none"
    spot_size: float = 45.0
    spot_blend: float = 0.15
    spot_model: Literal["cycles4", "cycles3"] = "cycles4"
    radius: float = 0.0  # as a point light's
    x_axis: Vec3 = (1.0, 0.0, 0.0)
    cone_scale: tuple[float, float] = (1.0, 1.0)
    # Blender's ray visibility of the light (Object > Visibility): False, it adds no diffuse term (visible_diffuse),
    # no highlight, glossy lobe, reflection of itself or reflection in rough glass (visible_glossy), or no light
    # through rough glass (visible_transmission)
    visible_diffuse: bool = True
    visible_glossy: bool = True
    visible_transmission: bool = True


@dataclass(frozen=True)
class AreaLight:
    """Blender's area light: a one-sided cosine emitter (Lambertian) of shape square, rectangle, disk or ellipse,
    size (x, y) metres along x_axis and the axis perpendicular to it and to direction, centred on location, shining
    along direction (Blender's local -Z). From a point P, each of its render.shadow_samples stratified sample points
    Q adds (intensity / samples) * max(0, cos_e) / |Q - P|^2 times the documented diffuse and specular terms, cos_e
    the cosine at the light between direction and P (docs/scene-format.md); 1 sample: the centre alone."""

    location: Vec3 = (0.0, 0.0, 5.0)
    direction: Vec3 = (0.0, 0.0, -1.0)
    x_axis: Vec3 = (1.0, 0.0, 0.0)
    shape: Literal["square", "rectangle", "disk", "ellipse"] = "square"
    size: tuple[float, float] = (1.0, 1.0)
    intensity: float = 1.0
    color: Color = WHITE
    # mirror and refracted rays that meet its front see its radiance (tracing/emitters.py), as Cycles' reflections
    # show a light's shape; False: the documented model (lights are points of light, seen only in highlights)
    seen_in_mirrors: bool = False
    visible_diffuse: bool = True  # Blender's ray visibility (Object > Visibility), as a spot's
    visible_glossy: bool = True
    visible_transmission: bool = True


Light = AmbientLight | PointLight | DirectionalLight | SpotLight | AreaLight | WorldLight


@dataclass(frozen=True)
class Camera:
    """Blender's camera: looks along its local -Z with local +Y up; lens and sensor in millimetres.

    type ORTHO: parallel rays from a view ortho_scale metres across (the fitted side), lens unused. shift_x, shift_y:
    Blender's lens shift, in units of the fitted side. clip_start, clip_end: camera rays start at the plane
    clip_start metres in front of the camera and stop at clip_end (planes, as Cycles does; None: no far limit);
    the documented camera has neither (rays from the camera itself, t from 0 to infinity). aperture: the radius in
    metres of a thin lens (depth of field, beyond the documented model; 0: a pinhole), whose rays through a point
    of the image meet on the plane focus_distance metres in front of the camera (camera.py)."""

    location: Vec3 = (7.36, -6.93, 4.96)
    rotation: Vec3 = (63.6, 0.0, 46.7)
    lens: float = 50.0
    sensor_width: float = 36.0
    sensor_height: float = 24.0
    sensor_fit: Literal["AUTO", "HORIZONTAL", "VERTICAL"] = "AUTO"
    type: Literal["PERSP", "ORTHO"] = "PERSP"
    ortho_scale: float = 6.0
    shift_x: float = 0.0
    shift_y: float = 0.0
    clip_start: float = 0.0
    clip_end: float | None = None
    aperture: float = 0.0
    focus_distance: float = 10.0
    # type PANO (Cycles' panoramic cameras, camera.py's panorama_direction): rays from the camera's location in the
    # directions the panorama type maps each image position to; fisheye_fov and the latitudes and longitudes in
    # degrees, fisheye_lens in millimetres (with the sensor's width and height, for the equisolid fisheye)
    panorama_type: Literal["EQUIRECTANGULAR", "FISHEYE_EQUIDISTANT", "FISHEYE_EQUISOLID", "MIRRORBALL"] = (
        "FISHEYE_EQUISOLID"
    )
    fisheye_fov: float = 180.0
    fisheye_lens: float = 10.5
    latitude_min: float = -90.0
    latitude_max: float = 90.0
    longitude_min: float = -180.0
    longitude_max: float = 180.0
    poses: tuple[Pose, ...] = ()  # motion blur: the camera's (location, rotation) over the shutter, as an object's


@dataclass(frozen=True)
class Vane:
    """The turning group: parts rotate by heading degrees about axis through pivot (right-handed)."""

    parts: tuple[str, ...] = ()
    pivot: Vec3 = (0.0, 0.0, 0.0)
    axis: Vec3 = (0.0, 0.0, 1.0)
    heading: float = 0.0
    name: str = "vane"


@dataclass(frozen=True, eq=False)
class Background(ArraysByBits):
    """solid: color for every miss; sky: a vertical gradient from horizon to zenith by the ray's elevation;
    documented: the seed's mode, every miss takes the sky's color at the canvas centre; none: black; image: an
    equirectangular picture looked up by the ray's direction (Blender's Environment Texture).

    image: (H, W, 3) float32 linear RGB, row 0 the picture's top (the zenith), read-only; rotation: degrees about Z
    (a Mapping node's Z rotation: the direction looked up is Rz(rotation) D); strength: multiplies it;
    interpolation: linear (bilinear between texel centres, wrapping around in longitude) or closest. Equality
    compares the image's bits (ArraysByBits)."""

    ARRAYS = ("image",)

    type: Literal["solid", "sky", "documented", "none", "image"] = "sky"
    color: Color = (0.05, 0.05, 0.05)
    horizon: Color = (0.75, 0.82, 0.9)
    zenith: Color = (0.25, 0.45, 0.8)
    image: np.ndarray | None = None
    rotation: float = 0.0
    strength: float = 1.0
    interpolation: Literal["linear", "closest"] = "linear"

    def __post_init__(self) -> None:
        if self.image is not None:
            object.__setattr__(self, "image", frozen_array(self.image, np.float32, (-1, -1, 3)))
        elif self.type == "image":
            raise ValueError('an "image" background needs its image (H, W, 3)')

    def __setstate__(self, state: dict) -> None:
        for value in state.values():
            if isinstance(value, np.ndarray):
                value.flags.writeable = False
        self.__dict__.update(state)

    def sky(self, elevation: float) -> Color:
        """The sky gradient for a ray whose direction has this z component (horizon below 0, zenith at 1)."""
        k = min(max(elevation, 0.0), 1.0)
        h, z = self.horizon, self.zenith
        return (h[0] + (z[0] - h[0]) * k, h[1] + (z[1] - h[1]) * k, h[2] + (z[2] - h[2]) * k)


@dataclass(frozen=True)
class RenderSettings:
    """samples is per pixel and a perfect square (stratified sqrt x sqrt grid); workers 0 means all cores."""

    width: int = 640
    height: int = 480
    depth: int = 3
    model: Literal["phong", "blinn-phong"] = "blinn-phong"
    coef: float = 3.0
    samples: int = 1
    workers: int = 0
    dtype: Literal["float32", "float64"] = "float64"
    seed: int = 0
    gate_specular: bool = False
    numerics: Literal["documented", "robust"] = "documented"  # tracer/geometry/robust.py
    pixel_aspect: tuple[float, float] = (1.0, 1.0)  # Blender's pixel_aspect_x, pixel_aspect_y
    film_transparent: bool = False  # misses of camera rays: colour 0 and alpha 0 (RenderResult.alpha)
    # Blender's render border: (min_x, min_y, max_x, max_y) fractions of the image, y up from the bottom; only the
    # pixels inside are traced, the others are 0 (alpha 0); crop: the image is the border's region only
    border: tuple[float, float, float, float] | None = None
    crop: bool = False
    passes: tuple[str, ...] = ()  # render passes beside the image (tracer/scene/passes.py), in the registry's order
    # Cryptomatte: the ranks kept per pixel (passes.cryptomatte_layers RGBA layers), and the names its IDs and manifest
    # give objects and materials where they are not the scene's own: (kind "object" or "material", scene name, name)
    cryptomatte_levels: int = 6
    cryptomatte_names: tuple[tuple[str, str, str], ...] = ()
    # the Mist pass: Blender's World > Mist Pass start and depth (metres) and falloff
    mist_start: float = 5.0
    mist_depth: float = 25.0
    mist_falloff: Literal["QUADRATIC", "LINEAR", "INVERSE_QUADRATIC"] = "QUADRATIC"
    # samples a pixel takes of each light of a size (area lights, a sun's angle, a light's radius), a perfect square:
    # a multi-jittered set over the light, from 9 one of four (lightsamples.patterned_grid); 1 = its centre alone (a
    # hard shadow)
    shadow_samples: int = 1
    # reflection rays a glossy material sends from each hit of a path's first glossy surface (one from the glossy
    # surfaces after it): the lobe's fixed stratified samples (lightsamples.glossy_pairs)
    glossy_samples: int = 16
    # indirect light between surfaces: the diffuse bounces a path may take (Cycles' Light Paths > Diffuse), each
    # hit's bounce by cosine-weighted rays at the glossy pairs; 0: none (the documented model)
    diffuse_bounces: int = 0
    # a time slice of motion blur (tracer/workers/shutter.py), (k, slices): the image plane's stratified grid has
    # samples * slices strata a pixel, and this slice traces `samples` of them, a different set in each slice and
    # pixel (camera.py's strata); None: the grid is the samples' own. Set by the shutter, not read from scene files.
    time_slice: tuple[int, int] | None = None
    # adaptive sampling's pass that flags the pixels to trace again (adaptive.steadied): the world light unshadowed
    # and its directions not turned pixel by pixel (camera.world_turns). Set by adaptive, not read from scene files.
    adaptive_flags: bool = False
    # adaptive sampling (tracer/workers/adaptive.py): 0 every pixel at `samples`; above 0, every pixel at a quarter
    # of them first and the full count again where a pixel differs by more than this (linear units) from the midpoint
    # of two opposite neighbours
    adaptive_threshold: float = 0.0


@dataclass(frozen=True)
class Scene:
    materials: dict[str, Material]
    objects: tuple[SceneObject, ...]
    lights: tuple[Light, ...]
    camera: Camera = field(default_factory=Camera)
    background: Background = field(default_factory=Background)
    render: RenderSettings = field(default_factory=RenderSettings)
    vane: Vane | None = None
    motion: Motion | None = None  # how the vane turns over time (wind or spin); None: it stands still

    def with_render(self, **changes: object) -> Scene:
        """The same scene with some render settings changed (CLI flags, benchmarks)."""
        return replace(self, render=replace(self.render, **changes))

    @property
    def has_alpha(self) -> bool:
        """Whether the render has an alpha channel: a transparent film, a holdout object, or a render border whose
        outside is kept (not cropped)."""
        settings = self.render
        if settings.film_transparent or (settings.border is not None and not settings.crop):
            return True
        return any(obj.holdout for obj in self.objects)

    @property
    def channels(self) -> int:
        """A traced pixel's channels: colour, alpha where the scene has one, then each pass's (passes.layout)."""
        from .passes import width

        levels = self.render.cryptomatte_levels
        return (4 if self.has_alpha else 3) + sum(width(name, levels) for name in self.render.passes)

    def with_heading(self, heading: float) -> Scene:
        """The same scene with the vane turned to heading degrees."""
        if self.vane is None:
            return self
        return replace(self, vane=replace(self.vane, heading=heading))
