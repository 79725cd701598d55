"""A bound of a valid range as an error message prints it (every one-line refusal that states a
range at these settings): four significant digits, rounded towards the inside of the range, so
that the printed end is accepted."""

from __future__ import annotations

import math


def printed_bound(x: float, down: bool, slack: float = 0.0) -> str:
    """``x`` to four significant digits, rounded down (``down``, an upper end) or up (a lower end);
    ``slack`` (in units of the last digit) treats an ``x`` that round-off put just past a printed
    value as that value (for checks with the same tolerance).  0 and non-finite ``x`` as %g."""
    if x == 0 or not math.isfinite(x):
        return "inf" if x == math.inf else f"{x:g}"
    q = 10.0 ** (math.floor(math.log10(abs(x))) - 3)
    v = (math.floor(x / q + slack) if down else math.ceil(x / q - slack)) * q
    return f"{v:.4g}"
