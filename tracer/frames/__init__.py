"""Layer 5, frames: sequences of scenes (animations, edits, an interactive view's coarse-to-fine levels) -> images,
tracing again only what changed; animations on a Dask cluster."""
