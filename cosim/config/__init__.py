"""What a run is: the paper's experiments (scenarios: T_ref and the end-effector path) and the
run's configuration (SimConfig: controller, compensator, plant and board parameters, and the
params-file validation of `--params`)."""
