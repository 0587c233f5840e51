"""Sensor error models of SPEC §11: each class samples one sensor from the true motion at its own rate."""
