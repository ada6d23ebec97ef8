"""The weathervane: panel settings and tracer scenes -> Blender objects, keyed motion, materials, lights, camera."""
