"""Experiment definitions, one module per reproduced paper (which model, filters and settings)."""
