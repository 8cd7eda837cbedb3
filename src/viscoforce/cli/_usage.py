"""The command line's usage error.

:class:`UsageError` is a command-line combination that cannot be run; the entry point prints it
and exits with status 2. It is re-exported by :mod:`viscoforce.cli._args`, where the commands
import it from.
"""

from __future__ import annotations

from viscoforce.exceptions import ViscoforceError

__all__ = ["UsageError"]


class UsageError(ViscoforceError, ValueError):
    """A command-line combination that cannot be run (exit status 2)."""
