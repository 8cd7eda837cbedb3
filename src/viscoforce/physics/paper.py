"""The paper's parameter set, in one place (P. Attard, Fig. 1 and Eq. 13).

Every default that says "the paper's value" reads it from :data:`PAPER`: the CLI flag defaults,
the tests and the benchmarks. The names are those of the command-line contract (``--R``, ``--P``,
``--Pw``, ``--z0``, ``--debye-length``, ``--E0``, ``--E-inf``, ``--tau``).
"""

from __future__ import annotations

from dataclasses import dataclass

from viscoforce._validation import require_positive, require_sls_moduli
from viscoforce.physics.materials import StandardLinearSolid
from viscoforce.physics.particle import Particle
from viscoforce.physics.surface_forces import DoubleLayer, SoftWall, SumOfLaws


@dataclass(frozen=True)
class PaperParameters:
    """The paper's system (Fig. 1 unless a figure says otherwise), SI units.

    Parameters
    ----------
    R : float
        Sphere radius [m] (10 µm).
    P : float
        Double-layer pressure scale [Pa] (1e7 Pa).
    debye_length : float
        Debye length 1/κ [m] (1 nm).
    Pw : float
        Soft-wall pressure [Pa] (1e7 Pa).
    z0 : float
        Soft-wall length [m] (0.5 nm).
    E0 : float
        Instantaneous modulus [Pa] (1e10 Pa, paper convention 2/E = Σ(1 − ν²)/E_i).
    E_inf : float
        Relaxed modulus [Pa] (1e9 Pa).
    tau : float
        Creep time τ of Eq. 3 [s] (1 ms).
    """

    R: float = 10e-6  # noqa: N815
    P: float = 1e7  # noqa: N815
    debye_length: float = 1e-9
    Pw: float = 1e7  # noqa: N815
    z0: float = 0.5e-9
    E0: float = 1e10  # noqa: N815
    E_inf: float = 1e9  # noqa: N815
    tau: float = 1e-3

    def __post_init__(self):
        for name in ("R", "P", "debye_length", "Pw", "z0"):
            object.__setattr__(self, name, require_positive(name, getattr(self, name)))
        e0, e_inf, tau = require_sls_moduli(self.E0, self.E_inf, self.tau)
        object.__setattr__(self, "E0", e0)
        object.__setattr__(self, "E_inf", e_inf)
        object.__setattr__(self, "tau", tau)

    def sphere(self) -> Particle:
        """The sphere of radius R."""
        return Particle(self.R)

    def pressure_law(self) -> SumOfLaws:
        """Eq. 13: double layer plus soft wall."""
        return DoubleLayer(self.P, self.debye_length) + SoftWall(self.Pw, self.z0)

    def material(self) -> StandardLinearSolid:
        """The standard linear solid of Eq. 3."""
        return StandardLinearSolid(E0=self.E0, E_inf=self.E_inf, tau=self.tau)


#: The paper's parameter set.
PAPER = PaperParameters()


def paper_pressure_law(P: float = PAPER.P, debye_length: float = PAPER.debye_length,  # noqa: N803
                       Pw: float = PAPER.Pw, z0: float = PAPER.z0) -> SumOfLaws:  # noqa: N803
    """The paper's Eq. 13, p(h) = P e^{−h/λ} + Pw (z0/h)^9 (defaults: the paper's values).

    Parameters
    ----------
    P : float
        Double-layer pressure scale [Pa].
    debye_length : float
        Debye length λ = 1/κ [m].
    Pw : float
        Soft-wall pressure [Pa].
    z0 : float
        Soft-wall length [m].
    """
    return DoubleLayer(P, debye_length) + SoftWall(Pw, z0)
