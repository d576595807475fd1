"""Set-up shared by every test process (each xdist worker imports this first)."""
from twin.parallel import one_blas_thread

# like the CLI and its workers: one BLAS thread per process (twin.parallel.one_blas_thread)
one_blas_thread()
