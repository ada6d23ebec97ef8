"""Layer 2, geometry: a Scene's objects and camera -> world-space primitives, vectorized ray kernels, hierarchies,
culling grids and swept volumes. Imports only the scene model."""
