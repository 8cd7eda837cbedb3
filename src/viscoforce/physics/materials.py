"""Linear viscoelastic materials, all reduced to one canonical creep Prony series.

Every material is represented by its creep compliance (paper Eqs. 3 and 8)

    C(t) = J_g + Σ_i ΔJ_i (1 − exp(−t/τ_i)),   J_g = 1/E0 (glassy),  J_g + Σ ΔJ_i = 1/E_inf,

in the paper's modulus convention (2/E = Σ(1 − ν²)/E_i, i.e. E = 2E* of Johnson). The τ_i are
*creep* (retardation) times — the decay times of C(t). For the standard linear solid the
stress-relaxation time is τ·E_inf/E0, which is not what ``tau`` means here.

Phase convention of the complex compliance: quantities vary as e^{+iωt}, so

    C*(ω) = J_g + Σ_i ΔJ_i / (1 + iωτ_i),   Im C* ≤ 0,   E*(ω) = 1/C*(ω),  Im E* ≥ 0,

and a force that leads the imposed compression has a positive phase angle.

The solvers only see :meth:`ViscoelasticMaterial.prony`, so a new material needs no solver code.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from viscoforce import closed_form
from viscoforce._typing import FloatArray
from viscoforce._validation import (
    as_float_1d,
    as_real_array,
    require_positive,
    require_sls_moduli,
)
from viscoforce.exceptions import ParameterError


@dataclass(frozen=True)
class Prony:
    """Canonical creep Prony data.

    Parameters
    ----------
    glassy_compliance : float
        J_g = 1/E0 [1/Pa].
    delta_compliances : tuple of float
        ΔJ_i > 0 [1/Pa].
    taus : tuple of float
        Creep (retardation) times τ_i > 0 [s], same length.
    """

    glassy_compliance: float
    delta_compliances: tuple[float, ...]
    taus: tuple[float, ...]

    @property
    def relaxed_compliance(self) -> float:
        """J_g + Σ ΔJ_i = 1/E_inf [1/Pa]."""
        return self.glassy_compliance + float(sum(self.delta_compliances))

    @property
    def n_modes(self) -> int:
        """Number of relaxation modes."""
        return len(self.taus)


class ViscoelasticMaterial(ABC):
    """A linear viscoelastic material in the paper's modulus convention.

    Subclasses implement :meth:`prony`; everything else derives from it.
    Phase convention: e^{+iωt}; C*(ω) = J_g + Σ ΔJ_i/(1 + iωτ_i) (Im C* ≤ 0).
    """

    @abstractmethod
    def prony(self) -> Prony:
        """The canonical creep Prony data."""

    @property
    def instantaneous_modulus(self) -> float:
        """Instantaneous (glassy) modulus E0 = 1/C(0) [Pa]."""
        return 1.0 / self.prony().glassy_compliance

    @property
    def relaxed_modulus(self) -> float:
        """Relaxed modulus E_inf = 1/C(∞) [Pa] (the static equilibrium modulus)."""
        return 1.0 / self.prony().relaxed_compliance

    def creep_compliance(self, t: ArrayLike) -> FloatArray:
        """Creep compliance C(t) [1/Pa] at times ``t`` [s] ≥ 0."""
        t = as_real_array("t", t)  # complex or text is refused here; the range in closed_form
        p = self.prony()
        return closed_form.prony_creep_compliance(t, p.glassy_compliance,
                                                  np.array(p.delta_compliances), np.array(p.taus))

    def complex_compliance(self, omega: ArrayLike) -> np.ndarray:
        """Complex compliance C*(ω) [1/Pa] at angular frequency ``omega`` [rad/s]."""
        omega = as_real_array("omega", omega)
        p = self.prony()
        return closed_form.prony_complex_compliance(omega, p.glassy_compliance,
                                                    np.array(p.delta_compliances), np.array(p.taus))

    def complex_modulus(self, omega: ArrayLike) -> np.ndarray:
        """Complex modulus E*(ω) = 1/C*(ω) [Pa]."""
        return 1.0 / self.complex_compliance(omega)

    def parameters(self) -> dict[str, float]:
        """Named parameters in SI (for dataset attrs)."""
        out: dict[str, float] = {}
        for k, v in vars(self).items():
            if isinstance(v, tuple):
                for i, x in enumerate(v):
                    out[f"{k}_{i + 1}"] = float(x)
            else:
                out[k] = float(v)
        return out


@dataclass(frozen=True)
class Elastic(ViscoelasticMaterial):
    """Purely elastic material.

    Parameters
    ----------
    E : float
        Modulus [Pa] in the paper's convention (2/E = Σ(1 − ν²)/E_i), > 0.
    """

    E: float  # noqa: N815

    def __post_init__(self):
        object.__setattr__(self, "E", require_positive("E", self.E))

    def prony(self) -> Prony:
        """No relaxation modes."""
        return Prony(1.0 / self.E, (), ())


@dataclass(frozen=True)
class StandardLinearSolid(ViscoelasticMaterial):
    """The paper's single-relaxation-time material, Eq. 3.

    Parameters
    ----------
    E0 : float
        Instantaneous modulus [Pa], > E_inf.
    E_inf : float
        Relaxed modulus [Pa], > 0.
    tau : float
        Creep time τ [s] (decay time of C(t); the stress-relaxation time is τ·E_inf/E0), > 0.
    """

    E0: float  # noqa: N815
    E_inf: float  # noqa: N815
    tau: float

    def __post_init__(self):
        e0, einf, tau = require_sls_moduli(self.E0, self.E_inf, self.tau)
        object.__setattr__(self, "E0", e0)
        object.__setattr__(self, "E_inf", einf)
        object.__setattr__(self, "tau", tau)

    def prony(self) -> Prony:
        """One mode: J_g = 1/E0, ΔJ = 1/E_inf − 1/E0, τ."""
        return Prony(1.0 / self.E0, (1.0 / self.E_inf - 1.0 / self.E0,), (self.tau,))


@dataclass(frozen=True)
class PronySeries(ViscoelasticMaterial):
    """n-mode creep Prony series C(t) = 1/E0 + Σ ΔJ_i (1 − e^{−t/τ_i}) (paper Eq. 8).

    Parameters
    ----------
    E0 : float
        Instantaneous modulus [Pa], > 0.
    delta_compliances : tuple of float
        ΔJ_i [1/Pa], each > 0.
    taus : tuple of float
        Creep times τ_i [s], each > 0, same length as ``delta_compliances``.
    """

    E0: float  # noqa: N815
    delta_compliances: tuple[float, ...]
    taus: tuple[float, ...]

    def __post_init__(self):
        object.__setattr__(self, "E0", require_positive("E0", self.E0))
        dj = as_float_1d("delta_compliances", self.delta_compliances)
        taus = as_float_1d("taus", self.taus)
        if dj.size != taus.size:
            raise ParameterError(
                f"delta_compliances and taus must have the same length, got {dj.size} and "
                f"{taus.size}")
        for i, (d, t) in enumerate(zip(dj, taus, strict=True)):
            require_positive(f"delta_compliances[{i}]", d)
            require_positive(f"taus[{i}]", t)
        object.__setattr__(self, "delta_compliances", tuple(float(x) for x in dj))
        object.__setattr__(self, "taus", tuple(float(x) for x in taus))

    @classmethod
    def from_moduli(cls, moduli: ArrayLike, taus: ArrayLike) -> PronySeries:
        """Paper Eq. 8 form: moduli E_0 > E_1 > … > E_n = E_inf and times τ_0 … τ_{n−1}.

        The mode i carries ΔJ_i = 1/E_{i+1} − 1/E_i.
        """
        e = as_float_1d("moduli", moduli, min_size=2)
        t = as_float_1d("taus", taus)
        if t.size != e.size - 1:
            raise ParameterError(
                f"taus must have len(moduli) - 1 = {e.size - 1} entries, got {t.size}")
        for i, x in enumerate(e):
            require_positive(f"moduli[{i}]", x)
        if np.any(np.diff(e) >= 0):
            raise ParameterError(f"moduli must be strictly decreasing (E_0 > ... > E_inf), got {e}")
        return cls(float(e[0]), tuple(1.0 / e[1:] - 1.0 / e[:-1]), tuple(t))

    def prony(self) -> Prony:
        """The stored modes."""
        return Prony(1.0 / self.E0, self.delta_compliances, self.taus)
