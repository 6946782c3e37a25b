"""Evaluation on ModelNet40: the paper's experiments, the classical baselines beside them."""
