"""Bridges to other robotics libraries (optional dependencies, imported on use)."""
