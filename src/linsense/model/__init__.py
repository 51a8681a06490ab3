"""Inductance models, frames, motor files and presets."""
