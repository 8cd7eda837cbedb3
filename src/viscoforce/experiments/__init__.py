"""Experiments: prescribed drives h0(t) and the protocols that use them."""

from __future__ import annotations

from .drives import Hold, MeasuredTrace, Ramp, Sequence, Sinusoid, Step, Triangle

__all__ = ["Hold", "Ramp", "Step", "Triangle", "Sinusoid", "Sequence", "MeasuredTrace"]
