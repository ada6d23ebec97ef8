"""Blender scenes -> tracer scene documents (meshes, materials, lights, world, passes); the tracer's model -> Cycles."""
