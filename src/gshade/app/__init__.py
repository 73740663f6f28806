"""The applications built on the library: the ``gshade`` command line, batch renders on
worker processes or a Dask cluster, and multi-panel report figures."""
