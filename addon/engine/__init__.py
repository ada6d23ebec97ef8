"""The tracer as Blender's render engine: F12, animations and the Rendered view -> traced images in Blender."""
