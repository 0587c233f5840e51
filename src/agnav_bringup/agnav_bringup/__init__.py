"""agnav configs, graph runner, evaluator and benchmarks (the agnav CLI)."""
