"""Layer 1, the scene model: JSON scene files, wind and vane settings -> frozen Scene dataclasses and the vane's
headings and keyframes. Imports nothing else from the tracer."""
