"""Many patches evaluated at once, and where a patch is irregular.

Grouped grids of derivatives (patches of one kind and degree in one matrix product), scattered
points through Bézier cells (numpy or one Dr.Jit kernel), B-spline batches, and the
regularised derivatives and normals at collapsed edges and corners."""
