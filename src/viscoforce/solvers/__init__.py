"""Numerics: Newton equilibria, time steppers and the time loop."""
