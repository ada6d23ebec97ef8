"""Layer 4, workers: a Scene -> a whole image, in bands of rows over a watched pool of worker processes, after
checking the memory and disk it needs."""
