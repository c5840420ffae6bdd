"""Small helpers for the demos' matplotlib figures."""

from __future__ import annotations

__all__ = ["latex_number"]


def latex_number(x: float) -> str:
    """``x`` for a LaTeX title: ``1e-06`` becomes ``10^{-6}``, ``0.015`` stays ``0.015``."""
    mantissa, _, exponent = f"{x:.3g}".partition("e")
    if not exponent:
        return mantissa
    power = f"10^{{{int(exponent)}}}"
    return power if mantissa == "1" else rf"{mantissa} \cdot {power}"
