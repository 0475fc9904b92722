"""One module per study: the computations behind each notebook, on the library and the seeds' problems."""
