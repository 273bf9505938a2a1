"""Evaluation against ground truth (`mvtrack eval`)."""
