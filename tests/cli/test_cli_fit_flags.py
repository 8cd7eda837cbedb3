"""The flags a model takes come from its registry entry (issue 36 item 1).

``viscoforce fit --model NAME`` refuses every model-input flag (of any entry) that NAME's entry
does not declare, naming it and the flags it does take; the ones it declares pass that check.
"""

from __future__ import annotations

import argparse

import pytest

from viscoforce.cli._args import UsageError
from viscoforce.cli._fit_inputs import _DEFAULTED, _flag_dest, _honoured, _refuse_unhonoured
from viscoforce.fitting.registry import MODELS

EVERY = sorted(set().union(*(e.flags for e in MODELS.values())) | {"--R"})


def _args(flag: str) -> argparse.Namespace:
    values = {_flag_dest(f): None for f in EVERY}
    values[_flag_dest(flag)] = True
    return argparse.Namespace(**values)


@pytest.mark.parametrize("name", list(MODELS))
@pytest.mark.parametrize("flag", [f for f in EVERY if f not in _DEFAULTED])
def test_a_flag_is_honoured_exactly_when_the_entry_declares_it(name, flag):
    if flag in _honoured(name):
        _refuse_unhonoured(_args(flag), name)
    else:
        with pytest.raises(UsageError, match=f"--model {name} cannot honour {flag} "):
            _refuse_unhonoured(_args(flag), name)


def test_the_entries_declare_the_flags_users_know():
    assert {"--h0", "--mean-force", "--R"} <= _honoured("svda")
    assert {"--tip", "--indentation", "--material", "--drag"} <= _honoured("contact")
    assert {"--tip", "--R"} <= _honoured("hertz")
    assert _honoured("prony") == set()
    assert {"--no-newtonian", "--fit-drag", "--contact-point"} <= _honoured("ting")
