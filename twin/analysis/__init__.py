"""What the twin's runs mean: the domain logic that turns recorded runs into figures.

Between the command line (twin.tools, which parses arguments and formats, prints and plots
what this package returns) and the runs (twin.runs | hardware, which produce the
recordings): the calibration fit and its uncertainty (calibration_fit), the paper's
evaluation (evaluation: Table I, held-out taps, the PCA figures' data), the comparison of
two runs (comparison), the data of the paper's Fig. 2 (shear) and the fidelity sweep with
its Pareto fronts (sweep). Results go back as values and as the data files a job records
(json, csv, yaml); nothing here parses a command line or draws (a test holds it).
"""
