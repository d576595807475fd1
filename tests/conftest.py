"""Set-up shared by every test process (each xdist worker imports this first)."""

import signal

from twin.runs.parallel import one_blas_thread

# like the CLI and its workers: one BLAS thread per process (twin.runs.parallel.one_blas_thread)
one_blas_thread()

# Tests send Ctrl-C to the commands they start, as a terminal would. A suite started in the
# background of a non-interactive shell (nohup …&, some CI runners) inherits SIGINT
# ignored, and so would those commands (an ignored signal stays ignored across exec);
# handled here, it is back to the default in every process a test starts.
signal.signal(signal.SIGINT, signal.default_int_handler)
