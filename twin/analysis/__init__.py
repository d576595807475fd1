"""What the twin's runs mean: the domain logic that turns recorded runs into figures.

Between the command line (twin.tools, which parses arguments and prints, writes and plots
what this package returns) and the runs (twin.runs | hardware, which produce the
recordings): the calibration fit and its uncertainty, the paper's evaluation tables and
footprint figures' data, the rig-versus-twin comparison, and the sweep's settings, probes
and Pareto fronts. Nothing here parses a command line or prints.
"""
