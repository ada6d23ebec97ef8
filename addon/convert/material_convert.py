"""A Blender material -> a tracer material (docs/scene-format.md) and one short line per thing it approximates.

The node tree that the active Material Output (target All or Cycles) uses is read as a sum of lobes: a diffuse colour
D, a mirror reflectance M, highlights (a colour weight G and a Blinn-Phong exponent n) and an emission E. Mix Shader
weighs its two inputs by its factor, Add Shader adds them. Then the documented material is

    reflective r    = mean(M)                          the documented mirror is white: a tinted mirror is named
    color           = D / (1 - r)                      the tracer weighs the local colour by 1 - r
    specular s      = n / coef (Blinn-Phong), n / 4 (Phong)     the twin's relation, inverted (vane/materials.py)
    specular_color  = G (n + 2) / 8 / (1 - r)          the twin's highlight_gain, inverted (clipped at 1, named)
    emission        = E                                added unshadowed, as Cycles adds it (up to 1e6)

Lobes of the shaders (F0 is a dielectric's reflectance at normal incidence, compat.principled_f0: 0.04 by default):

    Principled BSDF  specular F = metallic C + (1 - metallic) F0 (white for dielectrics, the base colour C for
                     metals); D = (1 - metallic)(1 - F0) C; E = Emission Color x Emission Strength
    Diffuse BSDF     D = C
    Glossy BSDF      F = C (Anisotropic in 3.4 too, its anisotropy named)
    Emission         E = Color x Strength

A specular F of a real weight (its mean above ROUGH_NAMED: a metal, a Glossy BSDF) rougher than rho 0.1 is the
format's glossy lobe (GGX of that roughness; Schlick's Fresnel for Principled, the colour for Glossy BSDF; the
node's distribution's energy, a rough Glass BSDF's too; Smith's shadowing separable in 3.x, as its Cycles).
Otherwise (a mirror, or a dielectric's few percent) a specular F splits by roughness rho into a mirror share and a
highlight share, and the highlight share of a Principled dielectric also reflects the world (a glossy lobe of
glossy_source "world"). The twin draws the documented
highlight of exponent n as a Beckmann lobe of roughness rho = (2 / (n + 2))^(1/4) (vane/materials.py), so rho maps back
to n = 2 / rho^4 - 2. A lobe at rho <= 0.1 (n >= 20000, narrower than any exponent the add-on's materials reach) is
a mirror; at rho >= 0.5 (n <= 30, a lobe 14 degrees wide) the scene's reflection is blurred past recognition and
only the lights' highlight is kept; in between the share moves linearly: mirror w = (0.5 - rho) / 0.4 of F, and
(1 - w) F is the highlight's weight. Where n < 1 (rho > 0.84) the highlight is as wide as a diffuse lobe and goes to D.

An Image Texture on Base Color (Principled) or Color (Diffuse BSDF) read by the mesh's UV map (its Vector input
unlinked, or from Texture Coordinate > UV or a UV Map node naming no map) or by Texture Coordinate > Generated (flat
projection reads their x and y: "uv_map" GENERATED, as below), flat projection, directly or through a
Mix (Mix or Multiply blend, a constant factor, a constant other colour), becomes the material's "texture": the
image's linear pixels (sRGB byte images decoded; float, Non-Color and Linear images as they are) through that Mix,
times the same factors as the colour (color = texture's mean), Closest or Linear (Cubic and Smart: Linear, named),
Repeat, Extend or Clip. A Checker or Gradient Texture read by the UV map (linked from Texture Coordinate UV or a UV Map
node) or by Generated coordinates (unlinked, as a new node comes, or from Texture Coordinate > Generated: "uv_map"
GENERATED, which the meshes' export turns into corner UVs, mesh_export.generated_uvs) becomes the format's checker or
gradient, a Gradient through a Color Ramp (Linear, Constant) the ramp's stops. A Mapping node rotating about Z alone
between the UV source and any of these becomes the texture's uv_scale, uv_offset and uv_rotation. A Color Ramp or
Hue/Saturation/Value node between an image or a checker and the input is applied to its texels or colours (exact for
Closest images and checkers; named on Linear images, where the node maps the interpolated colour). The same on Emission
Color and the Emission shader's Color becomes "emission_texture", times the strength. Anything else (other coordinates,
Mirror, other nodes in between) keeps the texture's mean colour, named (the means computed once per image or attribute
and kept in a cache). A Color Attribute node (or an Attribute node naming a colour attribute) becomes an "attribute"
texture of the meshes' corner colours, through the Mix nodes after it.

Glass and transparency are shares of the same sum: Glass BSDF (Color, IOR) and Refraction BSDF (its Fresnel
reflection added, named) are a clear dielectric of weight 1; Principled's Transmission t is one of weight (1 - m) t
after Metallic m, tinted by Base Color, of its IOR; Transparent BSDF lets the mean of its Color through; Principled's
Alpha a mixes the whole BSDF with a Transparent BSDF: (1 - a) clear, the rest scaled by a. Of the sum's clear weight p
and glass weight g, the material's alpha is 1 - p, its transmission g / (1 - p), and the opaque lobes, divided by their
share 1 - p - g, are the documented material the tracer weighs by alpha (1 - transmission). The format tints the
refracted light by color: the glass's tint where no opaque diffuse shows, else the opaque colour (named where they
differ). Glass rougher than 0.1 is the format's rough glass (transmission_roughness); below, sharp (named). A Mix
Shader switched by Light Path's Is Camera Ray or Is Shadow Ray takes the factor camera rays see, for every ray
(named). Subsurface, coat, sheen, thin film, normal and bump maps, and a volume beside a Surface are named and
rendered as the opaque base; a volume alone (no Surface: Cycles renders no surface) lets every ray through, named.
With no node tree the Viewport Display colour is the colour.
The add-on's own materials (vane/materials.py) convert back to exactly the values the panel holds.
"""

from __future__ import annotations

import math
import os

import bpy
import numpy as np

from .. import compat
from .. import tracer_api as tracer
from ..vane import materials
from . import node_tree
from .mesh_export import GENERATED
from .node_tree import hue_saturation

ROUGH_MIRROR = 0.1  # at or below: a mirror
ROUGH_HIGHLIGHT = 0.5  # at or above: a highlight of the lights only
DEFAULT_GREY = (0.8, 0.8, 0.8)  # Cycles' surface for an object without a material
# The scene format's colours lie in [0, 1] (the loader checks): a highlight brighter than that is clipped, named.
# Where the format lets specular_color be a weight above 1 (it allows up to 1e6), raise this.
MAX_COLOR = 1.0
MAX_EMISSION = 1e6  # emission is radiance, not a reflectance: the format takes it up to 1e6, as Cycles shows it
# A glass lobe's index of refraction: Cycles clamps it to at least 1e-5; Blender's IOR sockets stop at 1000
IOR_MIN, IOR_MAX = 1e-5, 1000.0
# a rough specular lobe's mean weight above which the blurred reflection it leaves out is named (a metal's base
# colour; a dielectric's 4% Fresnel reflectance is not)
ROUGH_NAMED = 0.1
SHARE_EPSILON = 1e-6  # a share of glass, transparency or the opaque rest below this is none

_means: dict[tuple, tuple[float, float, float]] = {}  # image or attribute -> its mean linear colour


def clear_cache() -> None:
    """Forget the cached mean colours (an image or a mesh's colours changed)."""
    _means.clear()


def exponent_from_roughness(roughness: float) -> float:
    """The Blinn-Phong exponent n whose twin lobe has this roughness: the inverse of rho = (2 / (n + 2))^(1/4)."""
    if roughness <= 0.0:
        return math.inf
    return max(0.0, 2.0 / roughness**4 - 2.0)


def specular_from_exponent(exponent: float, model: str = "blinn-phong", coef: float = 3.0) -> float:
    """The material's specular s for a half-vector exponent n (n = s * coef, or 4 s for Phong: vane/materials.py)."""
    return exponent / coef if model == "blinn-phong" else exponent / 4.0


def sharp(roughness: float) -> bool:
    """Whether a roughness is at most ROUGH_MIRROR as the user typed it: Blender keeps 0.1 as float32's
    0.10000000149, which a plain comparison took for rough (rough glass's sampled rays, 16 times the time)."""
    return compat.float32_decimal(roughness) <= ROUGH_MIRROR


def mirror_share(roughness: float) -> float:
    """The share of a specular lobe that is a mirror: 1 up to ROUGH_MIRROR, 0 from ROUGH_HIGHLIGHT, linear between."""
    if sharp(roughness):
        return 1.0
    return min(1.0, max(0.0, (ROUGH_HIGHLIGHT - roughness) / (ROUGH_HIGHLIGHT - ROUGH_MIRROR)))


class _Lobes:
    """A surface as the documented model's parts: diffuse, mirror, highlights and emission (linear RGB).

    texture: a texture in the diffuse, (pixels (H, W, 3) linear, bottom row first, as Blender's; its mean (3,);
    weight (3,); interpolation; extension; procedural (texture_input)): the diffuse at a point is
    diffuse + weight * (pixel - mean). emission_texture: the same in the emission."""

    def __init__(self) -> None:
        self.texture: tuple | None = None
        self.emission_texture: tuple | None = None
        self.textures_dropped = 0  # textures of shaders added to a textured one: only the first kept (named)
        self.diffuse = [0.0, 0.0, 0.0]
        # the diffuse as the colour inputs give it, before the conversion's own factors (Principled's diffuse share):
        # above 1 only where an input is, or inputs add up past 1
        self.given = [0.0, 0.0, 0.0]
        self.mirror = [0.0, 0.0, 0.0]
        self.highlights: list[tuple[list[float], float]] = []  # (colour weight, exponent n)
        self.emission = [0.0, 0.0, 0.0]
        # the surface's shares that are a clear dielectric (glass) and that let rays through (Transparent BSDF,
        # Principled Alpha): weights of the whole as the other lobes are; the glass's tint and IOR times its weight
        self.glass = 0.0
        self.glass_tint = [0.0, 0.0, 0.0]
        self.glass_ior = 0.0
        self.glass_roughness = 0.0  # the glass lobes' roughness times their weight (above ROUGH_MIRROR: rough)
        self.iors: set[float] = set()  # the IORs of the glass lobes (several: one, their weighted mean, named)
        # the energy and distribution of each rough glass lobe: "multiscatter" (GGX), "single" (GGX), "beckmann"
        self.glass_kinds: set[str] = set()
        self.clear = 0.0
        # the mean weight of specular lobes too rough for a mirror: what reflects the scene and world blurred in
        # Cycles, here only the lights' highlight (named where it is large: a rough metal, not a dielectric's 4%)
        self.rough = 0.0
        # rough specular lobes of a real weight (a metal, a Glossy BSDF): the format's glossy lobe (GGX), their
        # colour weights summed, their roughness weighted by mean weight; Fresnel and energy as their shaders'
        self.glossy = [0.0, 0.0, 0.0]
        self.glossy_roughness = 0.0  # sum of roughness times mean weight
        self.glossy_kinds: set[tuple[str, str]] = set()  # (fresnel, energy) of each lobe
        # a dielectric's rough specular (a few percent, its lights in the documented highlight): what it reflects
        # of the world, a glossy lobe of the world alone (glossy_source "world"), its roughness weighted as above
        self.sheen = [0.0, 0.0, 0.0]
        self.sheen_roughness = 0.0
        # the mean weight of specular lobes of a roughness above 0 made a sharp mirror (at most ROUGH_MIRROR): Cycles
        # shows the lights' highlight in them, a mirror shows no point of light (named)
        self.near_mirror = 0.0

    def scaled(self, k: float) -> _Lobes:
        out = _Lobes()
        out.diffuse = [c * k for c in self.diffuse]
        out.given = [c * k for c in self.given]
        out.mirror = [c * k for c in self.mirror]
        out.highlights = [([c * k for c in weight], n) for weight, n in self.highlights]
        out.emission = [c * k for c in self.emission]
        out.glass, out.glass_ior, out.clear = self.glass * k, self.glass_ior * k, self.clear * k
        out.glass_roughness = self.glass_roughness * k
        out.glass_tint = [c * k for c in self.glass_tint]
        out.rough = self.rough * k
        out.glossy = [c * k for c in self.glossy]
        out.glossy_roughness = self.glossy_roughness * k
        out.glossy_kinds = set(self.glossy_kinds) if k > 0.0 else set()
        out.sheen = [c * k for c in self.sheen]
        out.sheen_roughness = self.sheen_roughness * k
        out.near_mirror = self.near_mirror * k
        out.iors = set(self.iors) if k > 0.0 else set()
        out.glass_kinds = set(self.glass_kinds) if k > 0.0 else set()
        for name in ("texture", "emission_texture"):
            texture = getattr(self, name)
            if texture is not None:
                pixels, mean, weight, *rest = texture
                setattr(out, name, (pixels, mean, [w * k for w in weight], *rest))
        out.textures_dropped = self.textures_dropped
        return out

    def plus(self, other: _Lobes) -> _Lobes:
        out = _Lobes()
        out.diffuse = [a + b for a, b in zip(self.diffuse, other.diffuse, strict=True)]
        out.given = [a + b for a, b in zip(self.given, other.given, strict=True)]
        out.mirror = [a + b for a, b in zip(self.mirror, other.mirror, strict=True)]
        out.highlights = self.highlights + other.highlights
        out.emission = [a + b for a, b in zip(self.emission, other.emission, strict=True)]
        out.glass, out.glass_ior = self.glass + other.glass, self.glass_ior + other.glass_ior
        out.glass_roughness = self.glass_roughness + other.glass_roughness
        out.glass_tint = [a + b for a, b in zip(self.glass_tint, other.glass_tint, strict=True)]
        out.iors = self.iors | other.iors
        out.glass_kinds = self.glass_kinds | other.glass_kinds
        out.clear = self.clear + other.clear
        out.rough = self.rough + other.rough
        out.glossy = [a + b for a, b in zip(self.glossy, other.glossy, strict=True)]
        out.glossy_roughness = self.glossy_roughness + other.glossy_roughness
        out.glossy_kinds = self.glossy_kinds | other.glossy_kinds
        out.sheen = [a + b for a, b in zip(self.sheen, other.sheen, strict=True)]
        out.sheen_roughness = self.sheen_roughness + other.sheen_roughness
        out.near_mirror = self.near_mirror + other.near_mirror
        out.textures_dropped = self.textures_dropped + other.textures_dropped
        for name in ("texture", "emission_texture"):
            mine, theirs = getattr(self, name), getattr(other, name)
            setattr(out, name, mine if mine is not None else theirs)
            out.textures_dropped += int(mine is not None and theirs is not None)
        return out

    def add_glass(self, weight: float, tint, ior: float, roughness: float = 0.0, energy: str = "multiscatter") -> None:
        """A clear dielectric lobe of this weight, tint (linear RGB), index of refraction, roughness and, where rough,
        microfacet energy (_energy)."""
        ior = min(IOR_MAX, max(IOR_MIN, ior))
        if weight > 0.0 and not sharp(roughness):
            self.glass_kinds.add(energy)
        self.glass += weight
        self.glass_tint = [g + weight * c for g, c in zip(self.glass_tint, tint, strict=True)]
        self.glass_ior += weight * ior
        self.glass_roughness += weight * roughness
        if weight > 0.0:
            self.iors.add(ior)

    def add_specular(self, weight, roughness: float, fresnel: str = "constant", energy: str = "multiscatter") -> None:
        """A specular lobe of colour weight and roughness: a mirror up to ROUGH_MIRROR; above it, a glossy lobe
        (GGX) where its mean weight passes ROUGH_NAMED (a metal, a Glossy BSDF), else (a dielectric's few percent)
        the documented model's mirror share and highlight, or diffuse where it is that wide."""
        mean = sum(weight) / 3.0
        if not sharp(roughness) and mean > ROUGH_NAMED:
            self.glossy = [g + c for g, c in zip(self.glossy, weight, strict=True)]
            self.glossy_roughness += roughness * mean
            self.glossy_kinds.add((fresnel, energy))
            return
        share = mirror_share(roughness)
        if roughness > 0.0 and sharp(roughness):
            self.near_mirror += mean
        self.mirror = [m + share * c for m, c in zip(self.mirror, weight, strict=True)]
        rest = [(1.0 - share) * c for c in weight]
        if share >= 1.0 or not any(rest):
            return
        self.rough += sum(rest) / 3.0
        exponent = exponent_from_roughness(roughness)
        if exponent < 1.0:
            self.diffuse = [d + c for d, c in zip(self.diffuse, rest, strict=True)]
            self.given = [d + c for d, c in zip(self.given, rest, strict=True)]
        else:
            self.highlights.append((rest, exponent))
            if fresnel == "schlick":  # Cycles' dielectric reflects the world at every roughness, brighter at grazing
                self.sheen = [g + c for g, c in zip(self.sheen, rest, strict=True)]
                self.sheen_roughness += roughness * sum(rest) / 3.0


# --- inputs ----------------------------------------------------------------------------------------------------------


def _source(socket):
    """The node and output feeding socket in the flattened graph (through groups, reroutes and muted nodes), or
    (None, None)."""
    return node_tree.source(socket)


def _srgb_to_linear(c: float) -> float:
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


MISSING_COLOR = (1.0, 0.0, 1.0)  # Cycles' colour for an image it cannot load (TEX_IMAGE_MISSING_R, _G, _B)


def missing_file(image) -> str | None:
    """The absolute path of an image's file where Blender could not load it (None where it has pixels)."""
    if image.source not in ("FILE", "SEQUENCE", "TILED") or image.packed_file is not None:
        return None
    width, height = image.size  # asking for the size loads the file
    if width * height > 0 and image.has_data:
        return None
    return bpy.path.abspath(image.filepath, library=image.library)


def missing_note(image, label: str) -> str:
    path = missing_file(image)
    if image.source == "SEQUENCE" and path is not None and os.path.isfile(path):  # Cycles reads the frame's file
        return f'image sequence "{image.name}" on {label}: its frames are not read (Python gets no pixels): magenta'
    return f'image "{image.name}" on {label} not found ({path}): magenta, as Cycles shows it'


def linear_rgb(image):
    """An image's pixels as (height, width, 3) linear float64 (grey images repeated to three channels; 8-bit sRGB
    decoded); Cycles' magenta (one texel) where its file is missing; None where it has no pixels."""
    import numpy as np

    if missing_file(image) is not None:
        return np.asarray([[MISSING_COLOR]], dtype=np.float64)
    width, height = image.size
    if width * height == 0:
        return None
    pixels = np.empty(width * height * image.channels, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    channels = pixels.reshape(height, width, image.channels).astype(np.float64)
    rgb = channels[..., :3] if image.channels >= 3 else np.repeat(channels[..., :1], 3, axis=2)
    if not image.is_float and image.colorspace_settings.name in ("sRGB", "sRGB - Display"):
        rgb = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    if image.channels == 4 and getattr(image, "alpha_mode", "STRAIGHT") == "STRAIGHT":
        # Cycles keeps such an image premultiplied and its Color output divides by the alpha again: 0 where it is 0
        transparent = ~(channels[..., 3:4] > 0.0)
        _means[_transparent_key(image)] = bool(transparent.any())
        rgb = np.where(transparent, 0.0, rgb)
    return rgb


def _transparent_key(image) -> tuple:
    return ("transparent", image.name, tuple(image.size), image.filepath)


def transparent_texels(image) -> bool:
    """Whether a straight-alpha image has texels of alpha 0 (linear_rgb, which reads its pixels once, made them
    black)."""
    _rgba_pixels(image)
    return _means.get(_transparent_key(image), False)


def image_mean(image) -> tuple[float, float, float] | None:
    """An image's mean linear colour (cached by name, size and file); None where it has no pixels."""
    key = ("image", image.name, tuple(image.size), image.filepath)
    if key not in _means:
        rgb = linear_rgb(image)
        if rgb is None:
            return None
        _means[key] = tuple(float(c) for c in rgb.reshape(-1, 3).mean(axis=0))
    return _means[key]


def _render_color(attributes):
    """The colour attribute a Color Attribute node of no name reads in Cycles: the mesh's default for renders."""
    index = getattr(attributes, "render_color_index", -1)
    if 0 <= index < len(attributes):
        return attributes[index]
    return getattr(attributes, "active_color", None) or (attributes[0] if len(attributes) else None)


def attribute_mean(material, attribute_name: str) -> tuple[float, float, float] | None:
    """The mean of a colour attribute (no name: the render default) over the meshes that use material (cached); None
    where none has it."""
    key = ("attribute", material.as_pointer(), material.name, attribute_name)
    if key in _means:
        return _means[key]
    total, count = [0.0, 0.0, 0.0], 0
    for mesh in bpy.data.meshes:
        if material.name not in mesh.materials:
            continue
        attributes = getattr(mesh, "color_attributes", None) or getattr(mesh, "vertex_colors", None)
        if not attributes:
            continue
        layer = attributes.get(attribute_name) if attribute_name else _render_color(attributes)
        if layer is None:
            continue
        for item in layer.data:
            color = item.color
            total = [t + c for t, c in zip(total, color[:3], strict=True)]
            count += 1
    mean = tuple(t / count for t in total) if count else None
    _means[key] = mean
    return mean


def _unknown_attribute(material, node) -> bool:
    """Whether an Attribute node of type Geometry names nothing that the meshes using material have (no colour or
    other attribute, no UV map): an empty name, a typo, an attribute another object carries; never while a Geometry
    Nodes modifier could store it."""
    if getattr(node, "attribute_type", "GEOMETRY") != "GEOMETRY":
        return False
    name = node.attribute_name
    if not name:
        return True
    for mesh in bpy.data.meshes:
        if material is not None and material.name in mesh.materials:
            if mesh.attributes.get(name) is not None or mesh.uv_layers.get(name) is not None:
                return False
            colors = getattr(mesh, "vertex_colors", None)
            if colors is not None and colors.get(name) is not None:
                return False
    # a Geometry Nodes modifier may store it on the evaluated mesh (Store Named Attribute): not known to be missing
    return not any(modifier.type == "NODES" for obj in bpy.data.objects for modifier in getattr(obj, "modifiers", ()))


def color_input(socket, material, label: str, notes: list[str]) -> tuple[float, float, float]:
    """A colour input's value: a constant (node_tree.constant: its own, an RGB node's, arithmetic on constants), or
    the mean of an image or colour attribute (named)."""
    folded = node_tree.constant_color(socket)
    if folded is not None:
        return folded
    node, _ = _source(socket)
    own = tuple(float(c) for c in node_tree.wrap(socket).default_value[:3])
    if node is None:
        return own
    if node.bl_idname in ("ShaderNodeTexImage", "ShaderNodeTexEnvironment") and node.image is not None:
        if missing_file(node.image) is not None:
            notes.append(missing_note(node.image, label))
            return MISSING_COLOR
        mean = image_mean(node.image)
        if mean is not None:
            notes.append(f"image texture on {label}: mean colour")
            return mean
    if node.bl_idname in TEXTURE_NODES:  # a procedural texture (or a ramp, HSV) on other coordinates than the UV map
        found = texture_input(socket, label, [], uv_only=False)
        if found is not None:
            notes.append(f"{TEXTURE_NAMES[node.bl_idname]} on {label}: mean colour")
            return texture_mean(found)
    if node.bl_idname == "ShaderNodeAttribute" and _unknown_attribute(material, node):
        return (0.0, 0.0, 0.0)  # Cycles reads an attribute that no mesh has (an empty name too) as 0
    if node.bl_idname in ("ShaderNodeVertexColor", "ShaderNodeAttribute"):
        name = getattr(node, "layer_name", "") or getattr(node, "attribute_name", "")
        mean = attribute_mean(material, name)
        if mean is not None:
            notes.append(f"colour attribute on {label}: mean colour")
            return mean
    mixed = _mixed_means(node, material, label)
    if mixed is not None:  # e.g. glTF's image x colour attribute x factor: the product of their means
        notes.append(f"{node.path_name} of varying colours on {label}: its inputs' means mixed")
        return mixed
    notes.append(f"{node.path_name} on {label}: the input's own value")
    return own


def _mixed_means(node, material, label: str) -> tuple[float, float, float] | None:
    """A colour Mix node (a per-channel blend, a constant factor) of inputs that vary over the surface as the blend
    of their means (color_input), or None for anything else."""
    mix = _mix_sockets(node)
    if mix is None or any(part is None for part in mix[:3]):
        return None
    factor, first, second, blend = mix
    f = _constant_value(factor)
    if f is None:
        return None
    inner: list[str] = []
    a, b = (color_input(part, material, label, inner) for part in (first, second))
    if any(note.endswith("the input's own value") for note in inner):  # an input it could not read: not a mean
        return None
    mixed = node_tree.blend_colors(blend, min(1.0, max(0.0, f)), a, b)
    if mixed is not None and (getattr(node, "clamp_result", False) or getattr(node, "use_clamp", False)):
        mixed = tuple(min(1.0, max(0.0, c)) for c in mixed)
    return mixed


def _rgba_pixels(image) -> np.ndarray | None:
    """An image's linear pixels (H, W, 3), bottom row first, kept with the means' cache (by name, size and file)."""
    key = ("pixels", image.name, tuple(image.size), image.filepath)
    if key not in _means:
        _means[key] = linear_rgb(image)
    return _means[key]


INTERPOLATIONS = {"Closest": "closest", "Linear": "linear", "Cubic": "linear", "Smart": "linear"}
EXTENSIONS = {"REPEAT": "repeat", "EXTEND": "extend", "CLIP": "clip"}


GRADIENTS = {  # Blender's Gradient Texture types -> the scene format's
    "LINEAR": "linear",
    "QUADRATIC": "quadratic",
    "EASING": "easing",
    "DIAGONAL": "diagonal",
    "RADIAL": "radial",
    "QUADRATIC_SPHERE": "quadratic_sphere",
    "SPHERICAL": "spherical",
}
SPHERES = ("QUADRATIC_SPHERE", "SPHERICAL")  # the gradients that read z, which UVs from Generated coordinates lack
# A colour fed to a factor input: Cycles takes its luminance with the scene-linear space's coefficients (Rec. 709, the
# default OpenColorIO config's in 3.4 to 5.0)
LUMINANCE = np.asarray([0.2126, 0.7152, 0.0722])
TEXTURE_NAMES = {  # the nodes texture_input reads beside images and mixes, as the notes name them
    "ShaderNodeTexChecker": "checker texture",
    "ShaderNodeTexGradient": "gradient texture",
    "ShaderNodeValToRGB": "colour ramp",
    "ShaderNodeHueSaturation": "hue/saturation",
}
TEXTURE_NODES = tuple(TEXTURE_NAMES)
SEPARATE_NODES = ("ShaderNodeSeparateRGB", "ShaderNodeSeparateXYZ", "ShaderNodeSeparateColor")
GRID_MEAN = 64  # a gradient's mean colour: over GRID_MEAN^2 points of the unit UV square


def _uv_mapping(
    texture_node, unlinked_uv: bool = True, procedural: bool = False, generated: bool | None = None
) -> dict | None:
    """How a texture node reads the mesh's default UV map (_uv_coordinates), straight ({}) or through a Mapping node
    of constant settings rotating about Z alone ({"uv_scale": [su, sv], "uv_offset": [ou, ov], "uv_rotation": a}
    (degrees, where not 0): Point R(u S) + L, Vector R(u S), Texture S^-1 R^-1 (u - L) where the scale is uniform in
    u and v); None where it does not (a procedural texture also where the Mapping moves z: it reads (u, v, 0)).
    generated: whether Generated coordinates straight into the node are taken ({"uv_map": GENERATED}), by default
    for a procedural texture; an image's flat projection reads their (x, y) too."""
    node, _ = _source(texture_node.inputs["Vector"])
    if node is None or node.bl_idname != "ShaderNodeMapping":
        uv_map = _uv_coordinates(texture_node, unlinked_uv, generated=procedural if generated is None else generated)
        return None if uv_map is None else ({"uv_map": uv_map} if uv_map else {})
    kind = node.vector_type
    values = {name: _constant_vector(node.inputs.get(name)) for name in ("Location", "Rotation", "Scale")}
    if kind not in ("POINT", "TEXTURE", "VECTOR") or values["Scale"] is None or values["Rotation"] is None:
        return None
    rotation, uv_map = values["Rotation"], _uv_coordinates(node, False)
    if rotation[0] != 0.0 or rotation[1] != 0.0 or uv_map is None:
        return None
    named = {"uv_map": uv_map} if uv_map else {}
    scale, location = values["Scale"], values["Location"]
    if kind == "VECTOR":  # no location
        location = [0.0, 0.0, 0.0]
    if location is None:
        return None
    if procedural and location[2] != 0.0:
        return None
    turned = {"uv_rotation": math.degrees(rotation[2])} if rotation[2] != 0.0 else {}
    if kind != "TEXTURE":
        return {"uv_scale": scale[:2], "uv_offset": location[:2], **turned, **named}
    if scale[0] == 0.0 or scale[1] == 0.0 or (turned and scale[0] != scale[1]):
        return None  # the inverse rotates before it scales: with a rotation, only a uniform scale commutes
    cosine, sine = math.cos(-rotation[2]), math.sin(-rotation[2])
    x, y = location[0] * cosine - location[1] * sine, location[0] * sine + location[1] * cosine  # R^-1 L
    turned = {"uv_rotation": -turned["uv_rotation"]} if turned else {}
    return {
        "uv_scale": [1.0 / scale[0], 1.0 / scale[1]],
        "uv_offset": [-x / scale[0], -y / scale[1]],
        **turned,
        **named,
    }


def _constant_vector(socket) -> list[float] | None:
    """A vector input's value where it is a constant (node_tree.constant), else None (an absent socket: None)."""
    if socket is None:
        return None
    value = node_tree.constant_color(socket)
    return None if value is None else list(value)


def _uv_coordinates(texture_node, unlinked_uv: bool = True, generated: bool = False) -> str | None:
    """The UV map a texture node reads: "" for the mesh's default (its Vector unlinked: an Image Texture; procedural
    textures read Generated coordinates there: unlinked_uv False; a Texture Coordinate's UV output; a UV Map node
    that names no map), a UV Map node's map by name; with generated, mesh_export.GENERATED where it reads Generated
    coordinates (unlinked, or a Texture Coordinate's Generated output); None where it reads other coordinates."""
    node, output = _source(texture_node.inputs["Vector"])
    if node is None:
        return "" if unlinked_uv else GENERATED if generated else None
    if node.bl_idname == "ShaderNodeTexCoord":
        if getattr(node, "object", None) is not None:
            return None
        return "" if output.name == "UV" else GENERATED if generated and output.name == "Generated" else None
    if node.bl_idname == "ShaderNodeUVMap" and not getattr(node, "from_instancer", False):
        return getattr(node, "uv_map", "")
    return None


def _mix_sockets(node):
    """A colour Mix node's (factor, A, B) sockets and blend type (the Mix node of 3.4+, and MixRGB), or None."""
    if node.bl_idname == "ShaderNodeMix" and getattr(node, "data_type", "") == "RGBA":
        by_id = {socket.identifier: socket for socket in node.inputs}
        return by_id.get("Factor_Float"), by_id.get("A_Color"), by_id.get("B_Color"), node.blend_type
    if node.bl_idname == "ShaderNodeMixRGB":
        return node.inputs["Fac"], node.inputs["Color1"], node.inputs["Color2"], node.blend_type
    return None


def _constant_color(socket) -> np.ndarray | None:
    """A colour input's value where it is a constant (node_tree.constant), else None."""
    value = node_tree.constant_color(socket)
    return None if value is None else np.asarray(value, dtype=np.float64)


def _constant_value(socket) -> float | None:
    """A number input's value where it is a constant (node_tree.constant), else None."""
    return node_tree.constant_number(socket)


def texture_input(
    socket, label: str, notes: list[str], depth: int = 0, uv_only: bool = True, material=None
) -> tuple | None:
    """The texture a colour input reads by the mesh's UVs, as (pixels, interpolation, extension, procedural, mapping),
    or None where it is not one (the caller then takes the mean, named); mapping: _uv_mapping's fields:

    - an Image Texture: pixels (H, W, 3) linear, bottom row first; procedural None;
    - a Checker Texture: pixels its two colours (2, 1, 3) (white and black for its Fac); procedural
      {"checker": {"scale": s}};
    - a Gradient Texture, through a Color Ramp (Linear or Constant, RGB): pixels the ramp's colours (K, 1, 3);
      procedural {"gradient": {"type": t, "stops": positions, "interpolation": i}};
    - a Color Attribute node, or an Attribute node naming a colour attribute of material's meshes (with material
      given): pixels the images of black and white (2, 1, 3) under what follows (Mix nodes are affine);
      procedural {"attribute": {"name": n, "mean": the attribute's mean colour}};

    through Mix nodes (Mix, Multiply) with a constant factor and a constant other colour, and a Color Ramp (Linear or
    Constant, RGB) or a Hue/Saturation/Value node of constant settings applied to an image's texels or a checker's
    colours (exact; on a Linear image named: the node maps the interpolated colour, not the texels) or a gradient's
    own grey (exact: HSV scales a grey by fac Value + 1 - fac). uv_only False: any coordinates (for a mean colour)."""
    node, output = _source(socket)
    if node is None or depth > 8:
        return None
    kind = node.bl_idname
    if kind in ATTRIBUTE_NODES:
        return _attribute_texture(node, output, material)
    if kind == "ShaderNodeTexImage":
        image = node.image
        if image is None or output.name != "Color" or getattr(node, "projection", "FLAT") != "FLAT":
            return None
        mapping = _uv_mapping(node, generated=True)  # flat projection reads (x, y): Generated coordinates exactly
        if (uv_only and mapping is None) or node.extension not in EXTENSIONS:
            return None
        pixels = _rgba_pixels(image)
        if pixels is None:
            return None
        if missing_file(image) is not None:
            notes.append(missing_note(image, label))
        if image.source == "TILED" and len(image.tiles) > 1:
            notes.append(f"UDIM image on {label}: tile {image.tiles[0].number} over the whole surface")
        if node.interpolation in ("Cubic", "Smart"):
            notes.append(f"{node.interpolation.lower()} interpolation on {label}: linear")
        if node.interpolation != "Closest" and transparent_texels(image):  # Cycles interpolates them premultiplied
            notes.append(f"transparent texels of the image on {label}: black, interpolated into a darker edge")
        return pixels, INTERPOLATIONS.get(node.interpolation, "linear"), EXTENSIONS[node.extension], None, mapping or {}
    if kind == "ShaderNodeTexChecker":
        colors = [_constant_color(node.inputs[name]) for name in ("Color1", "Color2")]
        scale = _constant_value(node.inputs["Scale"])
        mapping = _uv_mapping(node, False, True)
        if (uv_only and mapping is None) or scale is None or any(c is None for c in colors):
            return None
        if output.name == "Fac":
            colors = [np.ones(3), np.zeros(3)]
        pixels = np.asarray(colors, dtype=np.float64)[:, None, :]
        return pixels, "closest", "repeat", {"checker": {"scale": scale}}, mapping or {}
    if kind == "ShaderNodeTexGradient":
        mapping = _uv_mapping(node, False, True)
        if (uv_only and mapping is None) or node.gradient_type not in GRADIENTS:
            return None
        if uv_only and (mapping or {}).get("uv_map") == GENERATED and node.gradient_type in SPHERES:
            return None  # a sphere reads z too, which the meshes' UVs do not carry: its mean (uv_only False)
        gradient = {"type": GRADIENTS[node.gradient_type], "stops": [0.0, 1.0], "interpolation": "linear"}
        return np.asarray([[[0.0] * 3], [[1.0] * 3]]), "closest", "repeat", {"gradient": gradient}, mapping or {}
    if kind == "ShaderNodeValToRGB":
        ramp = node.color_ramp
        if output.name != "Color" or ramp.color_mode != "RGB" or ramp.interpolation not in ("LINEAR", "CONSTANT"):
            return None
        found = texture_input(node.inputs["Fac"], label, notes, depth + 1, uv_only, material)
        return None if found is None else _ramped(found, ramp, label, notes)
    if kind == "ShaderNodeHueSaturation":
        settings = [_constant_value(node.inputs[name]) for name in ("Hue", "Saturation", "Value", "Fac")]
        found = texture_input(node.inputs["Color"], label, notes, depth + 1, uv_only, material)
        if found is None or any(value is None for value in settings) or "attribute" in (found[3] or {}):
            return None  # HSV is not affine: an attribute's colours cannot go through it here
        if "gradient" in (found[3] or {}) and not _plain_gradient(found):  # HSV is linear on greys only
            return None
        pixels, interpolation, extension, procedural, mapping = found
        if procedural is None and interpolation == "linear":
            notes.append(f"hue/saturation on a linear-interpolated image on {label}: on its texels")
        return hue_saturation(pixels, *settings), interpolation, extension, procedural, mapping
    mix = _mix_sockets(node)
    if mix is None or any(part is None for part in mix[:3]) or mix[3] not in ("MIX", "MULTIPLY"):
        return None
    factor, first, second, blend = mix
    f = _constant_value(factor)
    if f is None:
        return _texture_factor(node, mix, label, notes, depth, uv_only, material)
    f = min(1.0, max(0.0, f))
    found = [texture_input(part, label, notes, depth + 1, uv_only, material) for part in (first, second)]
    if (found[0] is None) == (found[1] is None):
        return None
    constant = _constant_color(second if found[0] is not None else first)
    if constant is None:
        return None
    pixels, interpolation, extension, procedural, mapping = found[0] if found[0] is not None else found[1]
    if blend == "MIX":
        mixed = pixels * (1.0 - f) + constant * f if found[0] is not None else constant * (1.0 - f) + pixels * f
    else:
        mixed = pixels * ((1.0 - f) + f * constant)
    if getattr(node, "clamp_result", False) or getattr(node, "use_clamp", False):
        mixed = np.clip(mixed, 0.0, 1.0)
    return mixed, interpolation, extension, procedural, mapping


def _texture_factor(
    node, mix: tuple, label: str, notes: list[str], depth: int, uv_only: bool, material
) -> tuple | None:
    """A Mix (blend Mix) of two constant colours A and B by a texture's value t: the texture with each texel's colour
    A (1 - t) + B t, t its luminance (Cycles' colour -> number) clamped to [0, 1] as the factor is. Exact: the mix is
    affine, so it commutes with a linear image's interpolation and a gradient's stops. None where A or B varies, the
    blend is another, or the factor is a colour attribute (its luminance is not a channel-wise map of its colour)."""
    factor, first, second, blend = mix
    a, b = _constant_color(first), _constant_color(second)
    if blend != "MIX" or a is None or b is None:
        return None
    found = texture_input(factor, label, notes, depth + 1, uv_only, material)
    if found is None or "attribute" in (found[3] or {}):
        return None
    pixels, interpolation, extension, procedural, mapping = found
    t = pixels @ LUMINANCE
    if getattr(node, "clamp_factor", True):  # the Mix node's Clamp Factor (on by default; MixRGB always clamps)
        clamped = np.clip(t, 0.0, 1.0)
        if interpolation == "linear" and procedural is None and not np.array_equal(t, clamped):
            notes.append(f"factor clamped on a linear-interpolated image's texels on {label}")
        t = clamped
    mixed = a * (1.0 - t[..., None]) + b * t[..., None]
    if getattr(node, "clamp_result", False) or getattr(node, "use_clamp", False):
        mixed = np.clip(mixed, 0.0, 1.0)
    return mixed, interpolation, extension, procedural, mapping


ATTRIBUTE_NODES = ("ShaderNodeVertexColor", "ShaderNodeAttribute")


def _attribute_texture(node, output, material) -> tuple | None:
    """A Color Attribute node, or an Attribute node (type Geometry) naming a colour attribute that material's meshes
    have, as an "attribute" texture (texture_input); None for anything else (its mean is then taken, named)."""
    if material is None or output.name != "Color":
        return None
    if node.bl_idname == "ShaderNodeAttribute":
        if node.attribute_type != "GEOMETRY" or not node.attribute_name:
            return None
        name = node.attribute_name
    else:
        name = node.layer_name
    mean = attribute_mean(material, name)
    if mean is None:
        return None
    black_and_white = np.asarray([[[0.0, 0.0, 0.0]], [[1.0, 1.0, 1.0]]])
    return black_and_white, "linear", "repeat", {"attribute": {"name": name, "mean": mean}}, {}


def _plain_gradient(found: tuple) -> bool:
    """Whether a texture (texture_input) is a gradient's own grey: black at 0 to white at 1, linear."""
    pixels, _, _, procedural, _ = found
    gradient = (procedural or {}).get("gradient")
    return (
        gradient is not None
        and gradient["stops"] == [0.0, 1.0]
        and gradient["interpolation"] == "linear"
        and pixels.shape[0] == 2
        and bool(np.all(pixels[0] == 0.0) and np.all(pixels[1] == 1.0))
    )


def _ramped(found: tuple, ramp, label: str, notes: list[str]) -> tuple | None:
    """A texture (texture_input) through a Color Ramp, as Cycles looks a ramp up (compat.cycles_ramp_table: the
    band's table of n entries at i / (n - 1), entry int(f (n - 1))): an image's texels and a checker's colours by
    their luminance; a plain gradient's grey replaced by the ramp's stops, a Constant ramp's each moved to the first
    table point at or past it (then the format's band steps where Cycles' table does; a Linear ramp's mix differs
    from the table's within 1 / (n - 1) of a stop); None for a gradient already through a ramp."""
    pixels, interpolation, extension, procedural, mapping = found
    size = compat.cycles_ramp_table()
    if procedural is not None and "attribute" in procedural:  # a ramp is not affine
        return None
    if procedural is not None and "gradient" in procedural:
        gradient = procedural["gradient"]
        if not _plain_gradient(found):
            return None
        elements = sorted(ramp.elements, key=lambda element: element.position)
        stops = [min(1.0, max(0.0, float(element.position))) for element in elements]
        if ramp.interpolation == "CONSTANT":
            stops = [min(1.0, math.ceil(p * (size - 1)) / (size - 1)) for p in stops]
        colors = np.asarray([[float(c) for c in element.color[:3]] for element in elements])[:, None, :]
        changed = {**gradient, "stops": stops, "interpolation": ramp.interpolation.lower()}
        return colors, interpolation, extension, {"gradient": changed}, mapping
    table = np.asarray([[float(c) for c in ramp.evaluate(i / (size - 1))[:3]] for i in range(size)])
    x = np.clip(pixels @ LUMINANCE, 0.0, 1.0) * (size - 1)
    i = np.clip(x.astype(np.int64), 0, size - 1)
    mapped = table[i]
    if ramp.interpolation == "LINEAR":
        t = (x - i)[..., None]
        mapped = np.where(t > 0.0, (1.0 - t) * mapped + t * table[np.minimum(i + 1, size - 1)], mapped)
    if procedural is None and interpolation == "linear":
        notes.append(f"colour ramp on a linear-interpolated image on {label}: on its texels")
    return mapped, interpolation, extension, procedural, mapping


def texture_mean(found: tuple) -> tuple[float, float, float]:
    """A texture's (texture_input) mean linear colour: an image's or a checker's colours' mean, a gradient's over
    the unit UV square (GRID_MEAN^2 points, as the tracer evaluates it)."""
    pixels, _, _, procedural, mapping = found
    if procedural is not None and "attribute" in procedural:  # black's and white's images: the map is affine
        black, white = pixels[0, 0], pixels[1, 0]
        return tuple(float(c) for c in black + (white - black) * np.asarray(procedural["attribute"]["mean"]))
    if procedural is None or "checker" in procedural:
        return tuple(float(c) for c in pixels.reshape(-1, 3).mean(axis=0))
    gradient = procedural["gradient"]
    texture = tracer.Texture(
        kind="gradient",
        gradient=gradient["type"],
        ramp=gradient["interpolation"],
        positions=tuple(gradient["stops"]),
        colors=tuple(tuple(float(c) for c in color) for color in pixels.reshape(-1, 3)),
        uv_scale=tuple(mapping.get("uv_scale", (1.0, 1.0))),
        uv_offset=tuple(mapping.get("uv_offset", (0.0, 0.0))),
        uv_rotation=float(mapping.get("uv_rotation", 0.0)),
    )
    centres = (np.arange(GRID_MEAN) + 0.5) / GRID_MEAN
    u, v = np.meshgrid(centres, centres)
    values = tracer.sample_texture(texture, u.reshape(-1), v.reshape(-1))
    return tuple(float(c) for c in values.mean(axis=1))


def value_input(socket, label: str, notes: list[str]) -> float:
    """A factor input's value where it is a constant (node_tree.constant); one that varies over the surface is named
    and read as the input's own value."""
    folded = node_tree.constant_number(socket)
    if folded is not None:
        return folded
    node, output = _source(socket)
    if node is not None and node.bl_idname in SEPARATE_NODES and getattr(node, "mode", "RGB") == "RGB":
        channel = [o.identifier for o in node.outputs].index(output.identifier)
        texture = texture_input(node.inputs[0], label, [], uv_only=False)
        if texture is not None and channel < 3:  # e.g. glTF's packed metallic (blue) and roughness (green)
            notes.append(f"a texture's channel on {label}: its mean")
            return float(texture_mean(texture)[channel])
    texture = texture_input(socket, label, [], uv_only=False)
    if texture is not None:
        what = "image texture" if texture[3] is None else TEXTURE_NAMES.get(node.bl_idname, node.bl_label.lower())
        if node.bl_idname == "ShaderNodeTexImage" and missing_file(node.image) is not None:
            notes.append(missing_note(node.image, label))
        else:
            notes.append(f"{what} on {label}: its mean")
        return float(np.asarray(texture_mean(texture)) @ LUMINANCE)
    notes.append(f"{node.path_name if node is not None else 'a node'} on {label}: the input's own value")
    return float(node_tree.wrap(socket).default_value)


# --- shaders ---------------------------------------------------------------------------------------------------------


def _textured_color(socket, material, label: str, notes: list[str]) -> tuple[tuple, tuple | None]:
    """A colour input's value and, where an image texture by UV feeds it (texture_input), that texture: its value
    is then the texture's mean."""
    texture = texture_input(socket, label, notes, material=material)
    if texture is None:
        return color_input(socket, material, label, notes), None
    return texture_mean(texture), texture


def _principled(node, material, notes: list[str]) -> _Lobes:
    lobes = _Lobes()
    base, texture = _textured_color(node.inputs["Base Color"], material, "Base Color", notes)
    metallic = min(1.0, max(0.0, value_input(node.inputs["Metallic"], "Metallic", notes)))
    roughness = min(1.0, max(0.0, value_input(node.inputs["Roughness"], "Roughness", notes)))
    level = value_input(compat.principled_socket(node, "specular"), "Specular", notes)
    f0 = compat.principled_f0(node, level)
    # Metallic first, then Transmission of the rest (a glass of the IOR tinted by Base Color), then the dielectric
    # specular over the diffuse: shares m, (1 - m) t and (1 - m)(1 - t), as Cycles layers them (3.4 and 4.0+)
    transmission = _transmission(node, notes)
    glass = (1.0 - metallic) * transmission
    dielectric = (1.0 - metallic) * (1.0 - transmission)
    lobes.diffuse = [dielectric * compat.principled_diffuse_factor(roughness, f0) * c for c in base]
    lobes.given = [dielectric * c for c in base]
    if texture is not None:
        weight = dielectric * compat.principled_diffuse_factor(roughness, f0)
        lobes.texture = (texture[0], base, [weight] * 3, *texture[1:])
        if metallic > 0.0:
            notes.append("metallic texture: its highlight of the texture's mean colour")
    lobes.add_specular([metallic * c + dielectric * f0 for c in base], roughness, "schlick", _energy(node, notes))
    if glass > 0.0:
        ior = value_input(node.inputs["IOR"], "IOR", notes)
        rough = compat.principled_transmission_roughness(node, roughness)
        lobes.add_glass(glass, compat.principled_transmission_tint(base), ior, rough)
        if rough > 0.0 and sharp(rough):
            notes.append("rough transmission: sharp")
        if "Specular IOR Level" in node.inputs and abs(level - 0.5) > 1e-6:  # 4.0+: it scales the glass's Fresnel too
            notes.append("Specular IOR Level on transmission: the IOR's own reflection")
        if texture is not None:
            notes.append("image texture on transmission: its mean colour")
    emission, glow = _textured_color(compat.principled_socket(node, "emission"), material, "Emission", notes)
    strength = value_input(node.inputs["Emission Strength"], "Emission Strength", notes)
    lobes.emission = [c * strength for c in emission]
    if glow is not None and strength != 0.0:
        lobes.emission_texture = (glow[0], emission, [strength] * 3, *glow[1:])
    for role, what in (("subsurface", "subsurface"), ("coat", "coat"), ("sheen", "sheen")):
        socket = compat.principled_input(node, role)
        if socket is not None and (socket.is_linked or float(socket.default_value) > 0.0):
            notes.append(f"{what}: rendered as the opaque base")
    tint = node.inputs.get("Specular Tint")
    if tint is not None and (
        tint.is_linked
        or (any(float(c) != 1.0 for c in tint.default_value[:3]) if tint.type == "RGBA" else tint.default_value > 0.0)
    ):
        notes.append("specular tint: white highlight")
    roughness_diffuse = node.inputs.get("Diffuse Roughness")
    if roughness_diffuse is not None and (roughness_diffuse.is_linked or float(roughness_diffuse.default_value) > 0.0):
        notes.append("diffuse roughness (Oren-Nayar): Lambert")
    anisotropic = compat.principled_input(node, "Anisotropic")
    if anisotropic is not None and (anisotropic.is_linked or float(anisotropic.default_value) != 0.0):
        notes.append("anisotropy: an isotropic highlight")
    _name_thin_film(node, notes)
    alpha = node.inputs.get("Alpha")
    coverage = 1.0 if alpha is None else min(1.0, max(0.0, value_input(alpha, "Alpha", notes)))
    if coverage >= 1.0:
        return lobes
    covered = lobes.scaled(coverage)  # Alpha mixes the whole BSDF (emission too) with a Transparent BSDF
    covered.clear += 1.0 - coverage
    return covered


def _transmission(node, notes: list[str]) -> float:
    """A Principled BSDF's Transmission (3.4) or Transmission Weight (4.0+) in [0, 1]."""
    socket = compat.principled_input(node, "transmission")
    if socket is None:
        return 0.0
    return min(1.0, max(0.0, value_input(socket, "Transmission", notes)))


def _name_thin_film(node, notes: list[str]) -> None:
    """4.2 and later: a thin film on Principled and Glass (iridescence) is not rendered."""
    thickness = node.inputs.get("Thin Film Thickness")
    if thickness is not None and (thickness.is_linked or float(thickness.default_value) > 0.0):
        notes.append("thin film: none")


def _glass(node, material, notes: list[str]) -> _Lobes:
    """Glass BSDF: a clear dielectric of its Color and IOR; Refraction BSDF: the same, its Fresnel reflection
    added (Cycles' Refraction BSDF refracts all the light it takes and reflects none)."""
    lobes = _Lobes()
    color = color_input(node.inputs["Color"], material, f"{node.name} Color", notes)
    ior = value_input(node.inputs["IOR"], f"{node.name} IOR", notes)
    roughness = value_input(node.inputs["Roughness"], f"{node.name} Roughness", notes)
    if getattr(node, "distribution", "") == "SHARP":  # 3.4's Sharp ignores the roughness
        roughness = 0.0
    roughness = min(1.0, max(0.0, roughness))
    if sharp(roughness):
        kind = "multiscatter"
    elif getattr(node, "distribution", "") == "BECKMANN":  # the format's Beckmann rough glass, single scattering
        kind = "beckmann"
    else:
        kind = _energy(node, notes)
    lobes.add_glass(1.0, color, ior, roughness, kind)
    if roughness > 0.0 and sharp(roughness):
        notes.append(f"rough {node.bl_label}: sharp")
    if node.bl_idname == "ShaderNodeBsdfRefraction":
        notes.append("Refraction BSDF: glass, its reflection added")
    elif max(color) - min(color) > 1e-3 or min(color) < 1.0 - 1e-3:
        notes.append("Glass BSDF colour: tints the refraction only")
    _name_thin_film(node, notes)
    return lobes


def _transparent(node, material, notes: list[str]) -> _Lobes:
    """Transparent BSDF: rays pass through it by its colour's mean (the rest of its weight is black)."""
    lobes = _Lobes()
    color = color_input(node.inputs["Color"], material, f"{node.name} Color", notes)
    clear = min(1.0, max(0.0, sum(color) / 3.0))
    lobes.clear = clear
    if max(color) - min(color) > 1e-3:
        notes.append("tinted transparency: grey of its mean")
    return lobes


def _glossy(node, material, notes: list[str]) -> _Lobes:
    lobes = _Lobes()
    color = color_input(node.inputs["Color"], material, f"{node.name} Color", notes)
    roughness = min(1.0, max(0.0, value_input(node.inputs["Roughness"], "Roughness", notes)))
    if getattr(node, "distribution", "") == "SHARP":  # 3.x: a perfect mirror whatever the roughness
        roughness = 0.0
    lobes.add_specular(list(color), roughness, "constant", _energy(node, notes))
    anisotropy = node.inputs.get("Anisotropy")
    if anisotropy is not None and (anisotropy.is_linked or float(anisotropy.default_value) != 0.0):
        notes.append("anisotropy: an isotropic highlight")
    return lobes


def _energy(node, notes: list[str]) -> str:
    """The glossy lobe's energy for a shader's microfacet distribution: Multiscatter GGX keeps what single
    scattering loses; GGX does not; Beckmann and Ashikhmin-Shirley are drawn as GGX of the same roughness
    (named)."""
    distribution = getattr(node, "distribution", "GGX")
    if distribution == "MULTI_GGX":
        return "multiscatter"
    if distribution in ("BECKMANN", "ASHIKHMIN_SHIRLEY"):
        notes.append(f"{distribution.replace('_', '-').title()} distribution: GGX")
    return "single"


def _diffuse(node, material, notes: list[str]) -> _Lobes:
    lobes = _Lobes()
    color, texture = _textured_color(node.inputs["Color"], material, f"{node.name} Color", notes)
    lobes.diffuse = list(color)
    lobes.given = list(lobes.diffuse)
    if texture is not None:
        lobes.texture = (texture[0], color, [1.0, 1.0, 1.0], *texture[1:])
    roughness = node.inputs.get("Roughness")
    if roughness is not None and (roughness.is_linked or float(roughness.default_value) > 0.0):
        notes.append("diffuse roughness (Oren-Nayar): Lambert")
    return lobes


def _emission(node, material, notes: list[str]) -> _Lobes:
    lobes = _Lobes()
    color, glow = _textured_color(node.inputs["Color"], material, f"{node.name} Color", notes)
    strength = value_input(node.inputs["Strength"], "Strength", notes)
    lobes.emission = [c * strength for c in color]
    if glow is not None and strength != 0.0:
        lobes.emission_texture = (glow[0], color, [strength] * 3, *glow[1:])
    return lobes


def _shader(socket, material, notes: list[str], depth: int = 0) -> _Lobes:
    """The lobes of whatever shader feeds socket."""
    node, _ = _source(socket)
    if node is None or depth > 32:
        return _Lobes()
    kind = node.bl_idname  # stable across versions (4.4 calls the Diffuse BSDF's type DIFFUSE_BSDF)
    if kind == "ShaderNodeBsdfPrincipled":
        return _principled(node, material, notes)
    if kind in ("ShaderNodeBsdfGlossy", "ShaderNodeBsdfAnisotropic"):
        return _glossy(node, material, notes)
    if kind == "ShaderNodeBsdfDiffuse":
        return _diffuse(node, material, notes)
    if kind == "ShaderNodeEmission":
        return _emission(node, material, notes)
    if kind in ("ShaderNodeBsdfGlass", "ShaderNodeBsdfRefraction"):
        return _glass(node, material, notes)
    if kind == "ShaderNodeBsdfTransparent":
        return _transparent(node, material, notes)
    if kind == "ShaderNodeAddShader":
        return _shader(node.inputs[0], material, notes, depth + 1).plus(
            _shader(node.inputs[1], material, notes, depth + 1)
        )
    if kind == "ShaderNodeMixShader":
        factor = _ray_switch(node, notes)
        if factor is None:
            factor = min(1.0, max(0.0, value_input(node.inputs[0], f"{node.name} Fac", notes)))
        first = _shader(node.inputs[1], material, notes, depth + 1).scaled(1.0 - factor)
        return first.plus(_shader(node.inputs[2], material, notes, depth + 1).scaled(factor))
    lobes = _Lobes()
    color = node.inputs.get("Color")
    if color is not None and hasattr(color, "default_value") and len(color.default_value) >= 3:
        lobes.diffuse = list(color_input(color, material, f"{node.name} Color", notes))
        notes.append(f"{node.bl_label}: a diffuse surface of its colour")
    else:
        lobes.diffuse = list(DEFAULT_GREY)
        notes.append(f"{node.bl_label}: grey diffuse")
    lobes.given = list(lobes.diffuse)
    return lobes


def _ray_switch(mix, notes: list[str]) -> float | None:
    """A Mix Shader's factor from Light Path's Is Camera Ray (1 for camera rays) or Is Shadow Ray (0 for them): the
    factor camera rays see, for every ray (named: e.g. glass whose shadow Cycles lets through); None otherwise."""
    node, output = _source(mix.inputs[0])
    if node is None or node.bl_idname != "ShaderNodeLightPath" or output.name not in ("Is Camera Ray", "Is Shadow Ray"):
        return None
    notes.append(f"Light Path {output.name} on {mix.name}: the shader camera rays see, for every ray")
    return 1.0 if output.name == "Is Camera Ray" else 0.0


def material_output(tree):
    """The Material Output that Cycles uses: the active one of target All or Cycles, else the first such (a
    node_tree.Node), or None."""
    outputs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial" and n.target in ("ALL", "CYCLES")]
    active = [n for n in outputs if n.is_active_output]
    found = (active or outputs or [None])[0]
    return None if found is None else node_tree.wrap(found)


# --- the add-on's own materials --------------------------------------------------------------------------------------

OWN_NODES = ("WV Diffuse", "WV Highlight", "WV Mix")


def _own(material, blender_scene, model: str, coef: float) -> dict | None:
    """An add-on material (vane/materials.py) back as its documented values: its "WV Surface" group node's Color,
    Shininess and Reflectivity, exactly (a material built before the group, its flat nodes read back through the
    twin's relations); None where its nodes are not the add-on's."""
    node = materials.top_node(material)
    if node is not None:
        color, specular, reflective = materials.node_values(node)
        return {
            "color": [compat.float32_decimal(c) for c in color],
            "specular": compat.float32_decimal(specular),
            "reflective": compat.float32_decimal(reflective),
        }
    nodes = material.node_tree.nodes if material.node_tree else None
    if nodes is None or any(nodes.get(name) is None for name in OWN_NODES):
        return None
    color = [float(c) for c in nodes["WV Diffuse"].inputs["Color"].default_value[:3]]
    reflective = float(nodes["WV Mix"].inputs["Fac"].default_value)
    highlight = nodes["WV Highlight"]
    specular = 0.0
    if any(float(c) > 0.0 for c in highlight.inputs["Color"].default_value[:3]):
        exponent = exponent_from_roughness(float(highlight.inputs["Roughness"].default_value))
        specular = specular_from_exponent(exponent, model, coef)
    entries = getattr(getattr(blender_scene, "weathervane", None), "materials", ())
    entry = next((e for e in entries if e.name == material.get("weathervane_material")), None)
    if (
        entry is not None
        and all(abs(a - b) <= 1e-6 for a, b in zip(entry.color, color, strict=True))
        and abs(entry.reflective - reflective) <= 1e-6
        and abs(entry.specular - specular) <= 1e-3 * max(1.0, entry.specular)
    ):
        color, specular, reflective = list(entry.color), entry.specular, entry.reflective
    return {
        "color": [compat.float32_decimal(c) for c in color],
        "specular": compat.float32_decimal(specular),
        "reflective": compat.float32_decimal(reflective),
    }


# --- the conversion --------------------------------------------------------------------------------------------------

# an emitting material while no light bounces between surfaces: Cycles lights the scene with it, the tracer only shows
# it (its diffuse bounces gather emission)
UNLIT_EMISSION = "emission lights nothing around it (Render Properties > Weathervane Tracer > Bounces 0)"


def emits(document: dict) -> bool:
    """Whether a converted material emits light."""
    return any(c > 0.0 for c in document.get("emission", ()))


def scene_notes(document: dict, blender_scene) -> list[str]:
    """What a converted material approximates in this scene's settings, beside its own conversion's notes: an emitting
    material under Bounces 0 lights nothing around it."""
    bounces = int(getattr(getattr(blender_scene, "weathervane", None), "diffuse_bounces", 0))
    return [UNLIT_EMISSION] if emits(document) and bounces == 0 else []


def convert_material(
    material,
    *,
    blender_scene=None,
    two_sided: bool | None = None,
) -> tuple[dict, list[str]]:
    """A Blender material (or None) -> (tracer material dict, notes on what it approximates).

    blender_scene gives the highlight model and coef (default: the context's scene); two_sided defaults to True for
    a material the add-on did not build (Blender lights both sides of a face), and is left out for the add-on's own.
    """
    blender_scene = blender_scene or bpy.context.scene
    settings = getattr(blender_scene, "weathervane", None)
    model = getattr(settings, "model", "blinn-phong")
    coef = float(getattr(settings, "coef", 3.0))
    notes: list[str] = []
    if material is None:
        return {"color": list(DEFAULT_GREY), "specular": 0, "reflective": 0, "two_sided": two_sided is not False}, [
            "no material: Cycles' grey"
        ]
    if compat.uses_nodes(material) and material.get("weathervane_material") is not None:
        own = _own(material, blender_scene, model, coef)
        if own is not None:
            if two_sided:
                own["two_sided"] = True
            return own, notes
    if not compat.uses_nodes(material):
        color = [min(1.0, max(0.0, float(c))) for c in material.diffuse_color[:3]]
        document = {"color": color, "specular": 0, "reflective": 0}
        notes.append("no node tree: its Viewport Display colour, diffuse")
        if two_sided is not False:
            document["two_sided"] = True
        return document, notes
    output = material_output(material.node_tree)
    volume = output is not None and output.inputs["Volume"].is_linked
    if output is None or not output.inputs["Surface"].is_linked:
        lobes = _Lobes()
        if volume:  # Cycles: a volume alone has no surface, every ray passes (a fog box around the scene)
            notes.append("a volume alone, no Surface: not rendered, every ray passes through (Cycles shows the volume)")
            lobes.clear = 1.0
        else:
            notes.append("no surface shader: black")
    else:
        lobes = _shader(output.inputs["Surface"], material, notes)
    if output is not None:
        if volume and output.inputs["Surface"].is_linked:
            notes.append("volume: left out, the surface alone")
        if output.inputs["Displacement"].is_linked:
            notes.append("displacement: ignored")
    _name_normal_maps(material.node_tree, notes)
    document = _document(lobes, model, coef, notes)
    if document.get("alpha", 1.0) < 1.0 and not compat.transparent_shadow(material):
        notes.append("Transparent Shadows off: its shadow lets 1 - alpha through")
    if two_sided is not False:
        document["two_sided"] = True
    _name_back_faces(material, document, notes, blender_scene, two_sided)
    return document, list(dict.fromkeys(notes))


# --- back faces (Geometry > Backfacing) -----------------------------------------------------------------------------


def _name_back_faces(material, document: dict, notes: list[str], blender_scene, two_sided) -> None:
    """The tree is read for front faces (Backfacing 0: what a camera sees of a closed mesh from outside); where it
    reads Geometry > Backfacing and converts to another material for back faces, what Cycles shows there is named."""
    if node_tree.facing_back() or not node_tree.reads_backfacing(material.node_tree):
        return
    with node_tree.back_faces():
        back, _ = convert_material(material, blender_scene=blender_scene, two_sided=two_sided)
    differs = _differences(document, back)
    if differs:
        notes.append(f"Backfacing: back faces shaded as the front (Cycles: {differs})")


def _differences(front: dict, back: dict) -> str:
    """What a material document for back faces has otherwise than the front's, in a few words ("" where nothing)."""
    if back.get("alpha", 1.0) <= SHARE_EPSILON and front.get("alpha", 1.0) > SHARE_EPSILON:
        return "transparent"
    words = []
    for key in sorted(set(front) | set(back)):
        a, b = front.get(key), back.get(key)
        if _same(a, b):
            continue
        try:
            shown = ", ".join(f"{float(v):.3g}" for v in np.atleast_1d(np.asarray(b, float)))
        except (TypeError, ValueError):  # a texture's fields
            shown = "another"
        words.append(f"{key.replace('_', ' ')} {'none' if b is None else shown}")
    return "; ".join(words)


def _same(a, b) -> bool:
    """Whether two values of material documents are equal (numbers within 1e-6, textures field by field)."""
    if isinstance(a, dict) or isinstance(b, dict):
        both = isinstance(a, dict) and isinstance(b, dict) and a.keys() == b.keys()
        return both and all(_same(a[key], b[key]) for key in a)
    try:
        x, y = np.asarray(a, float), np.asarray(b, float)
    except (TypeError, ValueError):
        return a == b
    return x.shape == y.shape and bool(np.allclose(x, y, atol=1e-6))


def _name_normal_maps(tree, notes: list[str]) -> None:
    for node in node_tree.nodes(tree):
        normal = node.inputs.get("Normal") if node.bl_idname.startswith("ShaderNodeBsdf") else None
        if normal is not None and normal.is_linked and not node_tree.own_normal(normal):
            notes.append("normal or bump map: the surface's own normal")
            return


def _shares(lobes: _Lobes, notes: list[str]) -> tuple[_Lobes, float, float, float | None, list[float] | None]:
    """The surface's coverage alpha a, glass share t of what it covers, the glass's IOR and tint, and the opaque
    rest's lobes as a whole surface: I = (1 - a) T + a ((1 - t) I_opaque + t glass), so of the lobes' weights p
    (transparent) and g (glass) a = 1 - p, t = g / a, and the opaque lobes are divided by their share 1 - p - g."""
    clear, glass = lobes.clear, lobes.glass
    if clear + glass > 1.0 + SHARE_EPSILON:
        notes.append("glass and transparency add up past 1: scaled to 1")
        clear, glass = clear / (clear + glass), glass / (clear + glass)
    if clear <= SHARE_EPSILON and glass <= SHARE_EPSILON:
        return lobes, 1.0, 0.0, None, None
    alpha = min(1.0, max(0.0, 1.0 - clear))
    transmission = min(1.0, glass / alpha) if alpha > SHARE_EPSILON else 0.0
    opaque = 1.0 - clear - glass
    if opaque > SHARE_EPSILON:
        rest = lobes.scaled(1.0 / opaque)
    else:
        rest = _Lobes()
        if any(lobes.diffuse) or any(lobes.mirror) or lobes.highlights or any(lobes.emission):
            notes.append("shaders added to full glass or transparency: left out")
    if transmission <= SHARE_EPSILON:
        return rest, alpha, 0.0, None, None
    tint = [c / lobes.glass for c in lobes.glass_tint]
    if len(lobes.iors) > 1:
        notes.append("glass of several IORs: their weighted mean")
    ior = compat.float32_decimal(next(iter(lobes.iors))) if len(lobes.iors) == 1 else lobes.glass_ior / lobes.glass
    return rest, alpha, transmission, ior, tint


def _glass_color(document: dict, rest: _Lobes, tint: list[float], notes: list[str]) -> None:
    """The format tints the refracted light by the material's color: the glass's tint where nothing opaque shows a
    diffuse, else the opaque colour (named where the tint differs from it by more than 0.05)."""
    tint = [min(1.0, max(0.0, c)) for c in tint]
    shows_diffuse = document["transmission"] < 1.0 and document["reflective"] < 1.0
    if not shows_diffuse or not any(c > 0.0 for c in rest.diffuse):
        if shows_diffuse and any(c > 0.0 for c in tint):
            notes.append("glass tint: also the colour of its opaque part")
        document["color"] = tint
    elif max(abs(a - b) for a, b in zip(document["color"], tint, strict=True)) > 0.05:
        notes.append("glass tint: the opaque part's colour")


def _document(lobes: _Lobes, model: str, coef: float, notes: list[str]) -> dict:
    rough = lobes.glass_roughness / lobes.glass if lobes.glass > 0.0 else 0.0  # the glass lobes' weighted mean
    glass_kinds = lobes.glass_kinds
    lobes, alpha, transmission, ior, tint = _shares(lobes, notes)
    document = _opaque_document(lobes, model, coef, notes)
    if transmission > 0.0:
        document["transmission"], document["ior"] = transmission, ior
        if not sharp(rough):  # sampled microfacets (GGX); a near-mirror stays sharp (named)
            document["transmission_roughness"] = min(1.0, rough)
            if "glossy" not in document and glass_kinds and glass_kinds <= {"single", "beckmann"}:
                document["glossy_energy"] = "single"  # the glass's distribution's energy: GGX and Beckmann lose some
            if glass_kinds == {"beckmann"}:
                document["transmission_distribution"] = "beckmann"
            elif "beckmann" in glass_kinds:
                notes.append("glass of several distributions: GGX")
        _glass_color(document, lobes, tint, notes)
    if ("glossy" in document or "transmission_roughness" in document) and compat.microfacet_shadowing() != "correlated":
        document["glossy_shadowing"] = compat.microfacet_shadowing()
    if alpha < 1.0:
        document["alpha"] = alpha
    return document


def _opaque_document(lobes: _Lobes, model: str, coef: float, notes: list[str]) -> dict:
    mirror = [min(1.0, max(0.0, c)) for c in lobes.mirror]
    reflective = sum(mirror) / 3.0
    if reflective > 0.0 and max(mirror) - min(mirror) > 1e-3:
        notes.append("tinted mirror: white at its mean reflectance")
    local = 1.0 / (1.0 - reflective) if reflective < 1.0 else 0.0
    color = [c * local for c in lobes.diffuse]
    if any(c > 1.0 + 1e-6 for c in lobes.given):  # a colour input above 1 (or inputs that add up past it)
        notes.append("diffuse colour above 1: clamped")
    elif any(c > 1.01 for c in color):  # inputs of at most 1 that 3.x Principled's Disney diffuse makes brighter
        notes.append("diffuse brighter than white (Principled's): white")
    if lobes.rough > ROUGH_NAMED:
        notes.append("rough reflection: sharp mirror share, lights' highlight; no blurred scene or world")
    if lobes.near_mirror > 0.0:
        notes.append("roughness up to 0.1: a sharp mirror, no highlight of the lights in it")
    document = {"color": [min(1.0, max(0.0, c)) for c in color], "specular": 0, "reflective": reflective}
    if any(c > 0.0 for c in lobes.glossy):
        _glossy_document(document, lobes, notes)
    elif any(c > 0.0 for c in lobes.sheen):
        document["glossy"] = [min(1.0, max(0.0, c)) for c in lobes.sheen]
        document["roughness"] = min(1.0, max(1e-4, lobes.sheen_roughness / (sum(lobes.sheen) / 3.0)))
        document["glossy_fresnel"], document["glossy_source"] = "schlick", "world"
    if lobes.texture is not None:
        document["texture"] = _texture_document(lobes.texture, lobes.diffuse, local)
    if lobes.textures_dropped:
        notes.append("several textures: the first's")
    if lobes.highlights:
        weight, exponent = max(lobes.highlights, key=lambda item: sum(item[0]))
        if len(lobes.highlights) > 1:
            total = [sum(w[i] for w, _ in lobes.highlights) for i in range(3)]
            weight = total
            notes.append("several highlights: one, of the strongest's exponent")
        gain = (exponent + 2.0) / 8.0 * local
        document["specular"] = specular_from_exponent(exponent, model, coef)
        highlight = [c * gain for c in weight]
        if max(highlight) > MAX_COLOR:
            notes.append("highlight brighter than a colour holds: clipped at 1")
        document["specular_color"] = [min(MAX_COLOR, c) for c in highlight]
    if any(c > 0.0 for c in lobes.emission):
        if max(lobes.emission) > MAX_EMISSION:
            notes.append("emission above 1e6: clipped")
        document["emission"] = [min(MAX_EMISSION, c) for c in lobes.emission]
    if lobes.emission_texture is not None and any(c > 0.0 for c in lobes.emission):
        glow = lobes.emission_texture
        document["emission_texture"] = _texture_document(glow, lobes.emission, 1.0, MAX_EMISSION)
        if "attribute" in (glow[5] or {}) and _texture_clipped(glow, lobes.emission, MAX_COLOR):
            notes.append("emission by a colour attribute above 1: clipped at 1")  # the format clamps it as a colour
    return document


def _glossy_document(document: dict, lobes: _Lobes, notes: list[str]) -> None:
    """The format's glossy lobe: the lobes' summed colour (clipped at 1, named), their mean roughness (weighted by
    weight; several roughnesses named) and their Fresnel and energy (several kinds: the first's, named)."""
    weight = sum(lobes.glossy) / 3.0
    if max(lobes.glossy) > 1.0 + 1e-6:
        notes.append("glossy colour above 1: clipped at 1")
    document["glossy"] = [min(1.0, max(0.0, c)) for c in lobes.glossy]
    document["roughness"] = min(1.0, max(1e-4, lobes.glossy_roughness / weight))
    kinds = sorted(lobes.glossy_kinds)
    fresnel, energy = kinds[0]
    if len(kinds) > 1:
        notes.append("glossy shaders of several kinds: one lobe, the first kind's Fresnel and energy")
    if fresnel != "constant":
        document["glossy_fresnel"] = fresnel
    if energy != "multiscatter":
        document["glossy_energy"] = energy


def _texture_values(texture: tuple, base, local: float) -> np.ndarray:
    """A lobe's texture's colours as the lobe has them: (base + weight (pixel - mean)) / (1 - r)."""
    pixels, mean, weight = texture[:3]
    offset = np.asarray(base, dtype=np.float64) - np.asarray(weight) * np.asarray(mean)
    return (pixels * np.asarray(weight) + offset) * local


def _texture_clipped(texture: tuple, base, high: float) -> bool:
    return bool(_texture_values(texture, base, 1.0).max() > high + 1e-6)


def _texture_document(texture: tuple, base, local: float, high: float = 1.0) -> dict:
    """The scene file's "texture" (or "emission_texture") of a textured lobe: its colours (_texture_values) clipped
    to [0, high] as the colour is; an image's pixels rows top first, float32 linear; a checker's two colours; a
    gradient's ramp stops."""
    interpolation, extension, procedural, mapping = texture[3:]
    mapping = {
        key: value if key == "uv_map" else float(value) if key == "uv_rotation" else [float(c) for c in value]
        for key, value in mapping.items()
    }
    if procedural is not None and "attribute" in procedural:  # the tracer maps each colour: gain c + bias, clamped
        black, white = _texture_values(texture, base, local)[:, 0]
        fields = {
            "name": procedural["attribute"]["name"],
            "gain": compat_color(white - black),
            "bias": compat_color(black),
        }
        return {"attribute": fields}
    values = np.clip(_texture_values(texture, base, local), 0.0, high)
    if procedural is not None and "checker" in procedural:
        one, two = (compat_color(c) for c in values[:, 0])
        return {"checker": {"color1": one, "color2": two, "scale": procedural["checker"]["scale"]}, **mapping}
    if procedural is not None:
        gradient = procedural["gradient"]
        stops = [[p, compat_color(c)] for p, c in zip(gradient["stops"], values[:, 0], strict=True)]
        fields = {"type": gradient["type"], "interpolation": gradient["interpolation"], "stops": stops}
        return {"gradient": fields, **mapping}
    values = np.ascontiguousarray(values[::-1], dtype=np.float32)
    values.flags.writeable = False
    document = {"pixels": values, "colorspace": "linear", "interpolation": interpolation, "extension": extension}
    return {**document, **mapping}


def compat_color(color) -> list[float]:
    """A colour as the scene file's list of three floats."""
    return [float(c) for c in color]
