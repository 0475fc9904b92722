"""One module per study: the computations behind each notebook, on the library and the seeds' problems.

The largest, ``orbit_transfer`` (notebook 05), is a package with a module per step of its chain; it re-exports
every name the notebook uses.
"""
