"""Layer 3, tracing: a Scene and its kernels -> colours of pixels (the vectorized wavefront tracer, the per-pixel
reference of the listings), ray trees kept for edits, and image files."""
