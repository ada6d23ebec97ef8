"""A render's image and passes -> one multilayer OpenEXR file named as Blender names its layers and passes.

Channels are "ViewLayer.Combined.R", "ViewLayer.Depth.Z", "ViewLayer.Normal.X", ... (Blender's own multilayer
files, which its compositor's Image node and Nuke read as layers), Cryptomatte as "ViewLayer.CryptoObject00.r" ...
in render.cryptomatte_levels' layers, with its manifest in the header, as the Cryptomatte specification and Cycles
write it."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..scene import passes as ps
from ..scene import scene as sc
from . import cryptomatte, exr

VIEW_LAYER = "ViewLayer"


def exr_channels(
    scene: sc.Scene, image: np.ndarray, alpha: np.ndarray | None, passes: dict[str, np.ndarray] | None
) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """image (H, W, 3), alpha (H, W) or None, passes as RenderResult.passes -> (channel name -> (H, W) float32,
    header attributes)."""
    channels = {f"{VIEW_LAYER}.Combined.{letter}": image[..., k] for k, letter in enumerate("RGB")}
    channels[f"{VIEW_LAYER}.Combined.A"] = np.ones(image.shape[:2]) if alpha is None else alpha
    header: dict[str, str] = {}
    for name, values in (passes or {}).items():
        if ps.PASSES[name].combine == "ranks":
            layer = f"{VIEW_LAYER}.{ps.PASSES[name].blender}"
            kind = "object" if name == "cryptomatte_object" else "material"
            header.update(cryptomatte.layer_header(layer, _names(scene, kind), kind))
        for k, channel in enumerate(pass_channel_names(name, scene.render.cryptomatte_levels)):
            channels[channel] = values[..., k]
    return {name: np.ascontiguousarray(values, dtype=np.float32) for name, values in channels.items()}, header


def pass_channel_names(name: str, levels: int = ps.CRYPTOMATTE_LEVELS) -> list[str]:
    """The file's channel names of the pass name, e.g. ["ViewLayer.Normal.X", "ViewLayer.Normal.Y", ...]; levels:
    the render's Cryptomatte levels (["ViewLayer.CryptoObject00.r", ... "ViewLayer.CryptoObject02.a"] for 6)."""
    definition = ps.PASSES[name]
    layer = f"{VIEW_LAYER}.{definition.blender}"
    if definition.combine == "ranks":
        return cryptomatte.channel_names(layer, levels)
    return [f"{layer}.{letter}" for letter in definition.channels]


def _names(scene: sc.Scene, kind: str) -> list[str]:
    """The names a Cryptomatte layer's manifest lists: every object's, or every material's, as Cryptomatte names
    them (render.cryptomatte_names)."""
    names = [obj.name for obj in scene.objects] if kind == "object" else list(scene.materials)
    return list(dict.fromkeys(cryptomatte.matte_names(names, scene.render, kind)))


def write_passes_exr(
    path: Path, scene: sc.Scene, image: np.ndarray, alpha: np.ndarray | None, passes: dict[str, np.ndarray] | None
) -> Path:
    """Writes the image and its passes to path (a multilayer .exr), atomically; returns path."""
    channels, header = exr_channels(scene, image, alpha, passes)
    exr.write_multilayer_exr(Path(path), channels, header)
    return Path(path)


def encode_passes_exr(
    scene: sc.Scene, image: np.ndarray, alpha: np.ndarray | None, passes: dict[str, np.ndarray] | None
) -> bytes:
    """The bytes of the file write_passes_exr writes (a cluster's worker sends them to the client, which writes)."""
    return exr.encode_multilayer_exr(*exr_channels(scene, image, alpha, passes))


def passes_file_is_complete(path: Path, scene: sc.Scene) -> bool:
    """Whether an earlier run's passes file at path is a whole EXR holding the scene's passes at its size (a file
    damaged or left by other settings is rendered again rather than trusted)."""
    try:
        channels, _ = exr.read_exr_channels(path)
    except (OSError, ValueError, RuntimeError):
        return False
    combined = channels.get(f"{VIEW_LAYER}.Combined.R")
    if combined is None or combined.shape != (scene.render.height, scene.render.width):
        return False
    levels = scene.render.cryptomatte_levels
    return all(channel in channels for name in scene.render.passes for channel in pass_channel_names(name, levels))
