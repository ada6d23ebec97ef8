"""tracer/tracing/exr.py: multilayer OpenEXR files written with the official bindings and read back, bit for bit."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from tracer.tracing import exr
from tracer.tracing.cryptomatte import channel_names, layer_header
from tracer.tracing.exr import read_exr_channels, write_multilayer_exr

HEIGHT, WIDTH = 7, 11


def awkward_floats(generator: np.random.Generator) -> np.ndarray:
    """(HEIGHT, WIDTH) float32 over every range a pass holds: huge, tiny, denormal, negative zero, inf, a NaN."""
    values = (generator.standard_normal((HEIGHT, WIDTH)) * 10.0 ** generator.integers(-30, 30, (HEIGHT, WIDTH))).astype(
        np.float32
    )
    values.flat[:6] = [np.float32(1e-45), -0.0, np.inf, -np.inf, np.finfo(np.float32).max, np.nan]
    return values


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return a.dtype == b.dtype == np.float32 and np.array_equal(a.view(np.uint32), b.view(np.uint32))


def test_several_layers_round_trip_bit_for_bit(tmp_path: Path) -> None:
    generator = np.random.default_rng(1)
    names = [
        "ViewLayer.Combined.R",
        "ViewLayer.Combined.G",
        "ViewLayer.Combined.B",
        "ViewLayer.Combined.A",
        "ViewLayer.Depth.Z",
        "ViewLayer.Normal.X",
        "ViewLayer.Normal.Y",
        "ViewLayer.Normal.Z",
        *channel_names("ViewLayer.CryptoObject", 4),
    ]
    channels = {name: awkward_floats(generator) for name in names}
    header = {**layer_header("ViewLayer.CryptoObject", ["Cube", "Sphere"]), "comment": "weathervane test"}
    path = tmp_path / "passes.exr"
    write_multilayer_exr(path, channels, header=header)
    read, attributes = read_exr_channels(path)
    assert sorted(read) == sorted(names)
    for name in names:
        assert read[name].shape == (HEIGHT, WIDTH)
        assert same_bits(read[name], channels[name]), name
    for key, value in header.items():
        assert attributes[key] == value
    assert "ZIP" in str(attributes["compression"])
    assert [file.name for file in tmp_path.iterdir()] == ["passes.exr"]  # no temporary left beside it


def test_blender_style_and_single_layer_names_are_kept_as_given(tmp_path: Path) -> None:
    channels = {name: np.full((HEIGHT, WIDTH), index, dtype=np.float32) for index, name in enumerate("RGBA")}
    channels["Combined.R"] = np.arange(HEIGHT * WIDTH, dtype=np.float64).reshape(HEIGHT, WIDTH)  # cast to float32
    channels["IndexOB.X"] = np.arange(HEIGHT * WIDTH, dtype=np.int32).reshape(HEIGHT, WIDTH)
    write_multilayer_exr(tmp_path / "plain.exr", channels)
    read, _ = read_exr_channels(tmp_path / "plain.exr")
    assert set(read) == {"R", "G", "B", "A", "Combined.R", "IndexOB.X"}
    assert all(array.dtype == np.float32 for array in read.values())
    assert np.array_equal(read["IndexOB.X"], channels["IndexOB.X"].astype(np.float32))
    assert np.array_equal(read["A"], np.full((HEIGHT, WIDTH), 3, dtype=np.float32))


def test_half_channels_are_stored_as_half(tmp_path: Path) -> None:
    values = np.linspace(0.0, 4.0, HEIGHT * WIDTH, dtype=np.float32).reshape(HEIGHT, WIDTH)
    write_multilayer_exr(tmp_path / "half.exr", {"Mist.Z": values, "Depth.Z": values}, half={"Mist.Z"})
    read, _ = read_exr_channels(tmp_path / "half.exr")
    assert read["Mist.Z"].dtype == np.float16
    assert np.array_equal(read["Mist.Z"], values.astype(np.float16))
    assert same_bits(read["Depth.Z"], values)


def test_a_failed_write_keeps_the_old_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "frame.exr"
    old = {"R": np.ones((HEIGHT, WIDTH), dtype=np.float32)}
    write_multilayer_exr(path, old)
    before = path.read_bytes()
    real = exr.openexr_module()

    class Breaking:
        """The bindings, except that a write stops halfway (a full disk, a kill)."""

        def __getattr__(self, name: str):
            return getattr(real, name)

        @staticmethod
        def File(header, channels):  # noqa: N802 - the bindings' name
            class Half:
                def write(self, target: str) -> None:
                    Path(target).write_bytes(b"\x76\x2f\x31\x01 half a file")
                    raise OSError("no space left on device")

            return Half()

    monkeypatch.setattr(exr, "openexr_module", lambda: Breaking())
    with pytest.raises(OSError, match="no space"):
        write_multilayer_exr(path, {"R": np.zeros((HEIGHT, WIDTH), dtype=np.float32)})
    assert path.read_bytes() == before
    assert [file.name for file in tmp_path.iterdir()] == ["frame.exr"]


def test_bad_input_is_refused_before_anything_is_written(tmp_path: Path) -> None:
    path = tmp_path / "bad.exr"
    plane = np.zeros((HEIGHT, WIDTH), dtype=np.float32)
    with pytest.raises(ValueError, match="at least one"):
        write_multilayer_exr(path, {})
    with pytest.raises(ValueError, match="one size"):
        write_multilayer_exr(path, {"R": plane, "G": np.zeros((HEIGHT, WIDTH + 1), dtype=np.float32)})
    with pytest.raises(ValueError, match="H, W"):
        write_multilayer_exr(path, {"RGB": np.zeros((HEIGHT, WIDTH, 3), dtype=np.float32)})
    with pytest.raises(TypeError, match="real numbers"):
        write_multilayer_exr(path, {"R": plane.astype(np.complex64)})
    with pytest.raises(ValueError, match="set by the writer"):
        write_multilayer_exr(path, {"R": plane}, header={"compression": "none"})
    with pytest.raises(ValueError, match="half"):
        write_multilayer_exr(path, {"R": plane}, half={"G"})
    assert not list(tmp_path.iterdir())


def test_without_the_bindings_the_error_says_how_to_install_them(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "OpenEXR", None)  # an import of it now fails as if it were not installed
    with pytest.raises(ImportError, match=r"pip install OpenEXR.*\.\[exr\]"):
        write_multilayer_exr(Path("never.exr"), {"R": np.zeros((2, 2), dtype=np.float32)})
    with pytest.raises(ImportError, match="pip install OpenEXR"):
        read_exr_channels(Path("never.exr"))


def test_the_bindings_are_installed() -> None:
    """`make test` installs them (the exr extra): their absence fails here rather than skipping the tests above."""
    import OpenEXR

    assert hasattr(OpenEXR, "File")


@pytest.mark.parametrize("command", ["render", "animate"])
def test_without_the_bindings_a_passes_run_says_so_before_it_renders(tmp_path: Path, command: str) -> None:
    import subprocess

    target = tmp_path / ("out.png" if command == "render" else "frames")
    frames = ["--frames", "1-2"] if command == "animate" else []
    script = (
        "import sys; sys.modules['OpenEXR'] = None\n"
        "from tracer.cli import main\n"
        f"sys.exit(main([{command!r}, *{frames!r}, '--passes', 'depth', '-o', {str(target)!r}, '--width', '8',"
        " '--height', '6']))"
    )
    root = Path(__file__).resolve().parents[1]
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=root, timeout=120)
    assert result.returncode == 1
    assert result.stderr.strip().splitlines() == [f"error: {target}: OpenEXR files need the OpenEXR Python bindings: "
                                                   f"{exr.INSTALL_HINT}"]  # fmt: skip
    assert not list(tmp_path.iterdir())  # nothing rendered, nothing written
