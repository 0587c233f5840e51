"""agnav simulator, closed-loop harness, evaluator, calibration and benchmarks: support for the product."""
