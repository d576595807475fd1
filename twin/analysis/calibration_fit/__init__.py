"""`twin calibrate`'s fit of the twin's parameters to recorded runs of one sensor, one job a
module: what is fitted and how (settings), the parameter space and the calibration it
maps to (space), the recorded pins (data), their simulation and the camera solve
(evaluator), the search over the physics parameters (search), the standard errors and
identifiability (uncertainty), and the fit itself (fit, whose docstring gives the model)."""
