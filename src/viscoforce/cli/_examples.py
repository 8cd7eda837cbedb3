"""The two examples that end each command's ``--help`` (one table; the test suite runs them).

Each example is one shell line, run verbatim from an empty folder by
``tests/cli/test_help_examples.py`` (several commands joined by ``&&`` run one after the other), so
it works wherever viscoforce is installed: its input files are ``example:NAME``, the example files
shipped inside viscoforce (:mod:`viscoforce.cli.examples`; ``viscoforce examples`` lists them,
``viscoforce examples --copy DIR`` copies them), and everything it writes lands in the current
folder. Examples stay fast (small grids, few samples): the suite runs every one.
"""

from __future__ import annotations

__all__ = ["EXAMPLES", "epilog"]

#: command → its two examples (shell lines).
EXAMPLES: dict[str, tuple[str, str]] = {
    "static": (
        "viscoforce static --h0=-5nm --modulus 1GPa --json",
        "viscoforce static --h0 2nm --modulus 1GPa --radius 20um --out static.nc",
    ),
    "simulate": (
        "viscoforce simulate --drive step --from 2nm --to -2nm --samples 51 --out step.nc "
        "--plot step.png",
        "viscoforce simulate --drive sine --h0 2nm --eta 0.1nm --omega 100Hz --periods 2 "
        "--samples 21 --json",
    ),
    "spectrum": (
        "viscoforce spectrum --h0 2nm --eta 0.1nm --omega-range 1Hz 1kHz 7 --json",
        "viscoforce spectrum --h0=-5nm --eta 0.1nm --omega 10Hz 628rad/s --out spectrum.nc "
        "--plot bode.png",
    ),
    "load": (
        "viscoforce load example:sls_modulation.jpk-force --out spectrum.nc",
        "viscoforce load example:sls_modulation.jpk-force --phase-lag 300Hz=2 --json",
    ),
    "fit": (
        "viscoforce fit example:sls_spectrum.csv --model exact --h0=-5nm --json",
        "viscoforce fit example:sls_step_relaxation.csv --model relaxation --out fit.csv "
        "--plot fit.png",
    ),
    "bode": (
        "viscoforce bode example:sls_spectrum.csv --plot bode.png",
        "viscoforce bode example:sls_spectrum.csv --model exact --h0=-5nm --plot fit.png "
        "--out fit.nc --json",
    ),
    "view": (
        "viscoforce fit example:sls_spectrum_map.nc --model exact --h0=-5nm --out fits.nc "
        "&& viscoforce view fits.nc --data example:sls_spectrum_map.nc --out map.html",
        "viscoforce fit example:sls_spectrum_map.nc --model exact --h0=-5nm --out fits.nc "
        "&& viscoforce view fits.nc --out map.html --json",
    ),
    "demo": (
        "viscoforce demo --out-dir demo",
        "viscoforce demo --out-dir demo --json",
    ),
    "examples": (
        "viscoforce examples",
        "viscoforce examples --copy my-examples sls_spectrum.csv && viscoforce fit "
        "my-examples/sls_spectrum.csv --model exact --h0=-5nm --json",
    ),
}


def epilog(command: str) -> str:
    """The ``--help`` epilog of ``command``: its examples, one per line (``""`` if none)."""
    lines = EXAMPLES.get(command)
    if not lines:
        return ""
    return ("examples (example:NAME is a file shipped with viscoforce: `viscoforce examples` "
            "lists them):\n" + "\n".join(f"  {line}" for line in lines))
