"""Broken variants of emitted C for the tests that must catch them: one anchored edit."""

from __future__ import annotations


def edited(c: str, old: str, new: str, times: int = 1) -> str:
    """`c` with `old` replaced by `new`, after checking that `old` occurs exactly `times`
    times (an anchor that moved fails here instead of leaving the variant unbroken).

    Example:
        >>> edited("a = b; c = b;", "b;", "0;", times=2)
        'a = 0; c = 0;'
    """
    found = c.count(old)
    assert found == times, f"{old!r} occurs {found} times in the emitted C, not {times}"
    return c.replace(old, new)
