"""Nutty: a programmable robot animation engine."""

__version__ = "0.1.0"
