"""Image regression: comparisons with idiff's thresholds or a z-test, difference images, and
the reference checks of ``gshade check`` with their HTML report."""
