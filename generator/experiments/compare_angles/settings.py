"""What `s2gen compare-angles` runs and the names of the forms it compares (imports nothing
heavy, so that the command-line parser can show the defaults).

Input: nothing. Output: `FORMS` and their labels, the reference tolerances, `ZOOM`, `Settings`.

Example:
    >>> Settings().options().rtol, FORMS[0], _LABELS["s2"]
    (1e-06, 's2', 'S² form')
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from s2gen import Options

__all__ = ["FORMS", "ZOOM", "Settings"]

#: The forms compared: the S^2 form, the angle form as derived, the angle form simplified.
FORMS = ("s2", "angles", "angles-simplified")
_LABELS = {"s2": "S² form", "angles": "angle form", "angles-simplified": "angle form, simplified"}
_REFERENCE_RTOL, _REFERENCE_ATOL = 1e-12, 1e-14
#: Half width of the time window around a pole pass shown in detail (figures, step counts).
ZOOM = 0.15


@dataclass(frozen=True)
class Settings:
    """What to run. `budget`: seconds per derivation; `windows`: S^2 step-count resolution."""

    T: float = 10.0
    h: float = 0.01
    rtol: float = 1e-6
    atol: float = 1e-9
    control: str = "matlab"
    budget: float = 120.0
    tilts: tuple[float, ...] = (1e-1, 1e-2, 1e-3, 1e-4)
    alpha: float = 0.5
    chain_max: int = 10
    repeats: int = 5
    windows: int = 50

    @staticmethod
    def quick() -> Settings:
        """Short runs for a smoke test (about a minute).

        Example:
            >>> Settings.quick().chain_max
            3
        """
        return Settings(T=2.0, budget=30.0, tilts=(1e-2, 1e-4), chain_max=3, repeats=3, windows=10)

    def options(self) -> Options:
        """The RK45 options of the runs compared."""
        from s2gen import Options

        return Options(rtol=self.rtol, atol=self.atol, control=self.control)

    def reference_options(self) -> Options:
        """The RK45 options of the converged S^2 reference (rtol 1e-12, atol 1e-14).

        Example:
            >>> Settings().reference_options().rtol
            1e-12
        """
        from s2gen import Options

        return Options(rtol=_REFERENCE_RTOL, atol=_REFERENCE_ATOL, control=self.control)
