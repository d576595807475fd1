"""Set-up shared by every test process (each xdist worker imports this first)."""

from twin.runs.parallel import one_blas_thread

# like the CLI and its workers: one BLAS thread per process (twin.runs.parallel.one_blas_thread)
one_blas_thread()
