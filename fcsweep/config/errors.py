"""Config errors: one message per problem, all problems of a file at once, and the
value checks every section uses (integers, finite numbers, did-you-mean)."""

from __future__ import annotations

import difflib
import math
import re
import reprlib
from typing import Mapping

import numpy as np


def _one_line(message) -> str:
    return re.sub(r"\s*[\r\n]+\s*", " ", str(message)).strip()


class ConfigError(ValueError):
    """An invalid sweep configuration; the message names key, value and what is allowed.

    Every problem is one line (line breaks of quoted parser messages are folded).  A file
    with one problem gives a one-line message, exactly ``"<source>: <problem>"`` when
    ``source`` is given; a file with several gives a first line
    ``"<source>: <n> problems:"`` and then one indented line per problem (at most
    :data:`MAX_LISTED`, then how many more).

    Parameters
    ----------
    message : str
        The problem (ignored when ``problems`` is given).
    problems : sequence of str, optional
        Several problems of one file, reported together.
    source : str, optional
        The file they concern, prefixed to the message.

    Attributes
    ----------
    problems : tuple of str
        The problems, one line each, without ``source``.
    source : str
    """

    def __init__(self, message: str = "", *, problems=None, source: str = ""):
        self.problems = tuple(_one_line(p) for p in (problems if problems else [message]))
        self.source = str(source)
        prefix = f"{self.source}: " if self.source else ""
        if len(self.problems) == 1:
            text = prefix + self.problems[0]
        else:
            shown = self.problems[:MAX_LISTED]
            more = len(self.problems) - len(shown)
            text = f"{prefix}{len(self.problems)} problems:" + "".join(f"\n  {p}" for p in shown)
            if more:
                text += f"\n  ... and {more} more"
        super().__init__(text)

    def with_source(self, source: str) -> "ConfigError":
        """The same problems, prefixed with ``source`` (replacing any source it had)."""
        return ConfigError(problems=self.problems, source=source)


#: Most problems one :class:`ConfigError` lists (the first line still counts all).
MAX_LISTED = 30


#: Sentinel of a value whose check failed (its problem is recorded in a :class:`ConfigProblems`).
FAILED = object()


class ConfigProblems:
    """The problems of one file, collected so that all are reported at once."""

    def __init__(self):
        self.messages: list[str] = []

    @property
    def count(self) -> int:
        return len(self.messages)

    def add(self, exc: ConfigError) -> None:
        for p in exc.problems:
            if p not in self.messages:
                self.messages.append(p)

    def attempt(self, fn, *args, **kwargs):
        """``fn(*args, **kwargs)``, or :data:`FAILED` with its ConfigError recorded."""
        try:
            return fn(*args, **kwargs)
        except ConfigError as exc:
            self.add(exc)
            return FAILED

    def keys(self, d: Mapping, allowed, where: str) -> set:
        """Record every key of ``d`` not in ``allowed``; return the keys suggested instead
        (a section misspelled as a suggested key is not reported missing as well)."""
        suggested = set()
        for k in d:
            if k not in allowed:
                self.add(unknown_key(k, allowed, where))
                hint = _suggest(k, allowed)
                if hint is not None:
                    suggested.add(hint)
        return suggested

    def raise_if_any(self, source: str = "") -> None:
        if self.messages:
            raise ConfigError(problems=self.messages, source=source)


#: Message of the safety net in :func:`parse_config` (tests assert it never appears).
UNCHECKED = "a value no check anticipated"

_REPR = reprlib.Repr()
_REPR.maxstring = _REPR.maxother = 60
_REPR.maxlist = _REPR.maxdict = _REPR.maxset = _REPR.maxtuple = 8
_REPR.maxlevel = 3


def show_value(value) -> str:
    """``repr`` cut to one short line (values may be huge or deeply nested)."""
    try:
        return _REPR.repr(value)
    except (ValueError, RecursionError):  # e.g. an int beyond str()'s digit limit
        return f"<{type(value).__name__}>"


def _edit_distance(a: str, b: str) -> int:
    """Optimal-string-alignment distance (insertions, deletions, substitutions, swaps)."""
    prev2, prev = None, list(range(len(b) + 1))
    for i, ca in enumerate(a, 1):
        cur = [i] + [0] * len(b)
        for j, cb in enumerate(b, 1):
            cur[j] = min(prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (ca != cb))
            if prev2 is not None and i > 1 and j > 1 and ca == b[j - 2] and a[i - 2] == cb:
                cur[j] = min(cur[j], prev2[j - 2] + 1)
        prev2, prev = prev, cur
    return prev[-1]


def _suggest(key, allowed) -> str | None:
    """The allowed key ``key`` most likely misspells, or ``None``: difflib's closest match,
    else one that differs only in case, else (keys of 2+ characters, where difflib's
    ratio is too coarse: ``vo`` for ``v0``) one a single edit away."""
    allowed = [str(a) for a in allowed]
    key = str(key)
    close = difflib.get_close_matches(key, allowed, n=1, cutoff=0.6)
    if not close:
        close = [a for a in allowed if a.lower() == key.lower()]
    if not close and 2 <= len(key) <= 40:
        close = [a for a in allowed if _edit_distance(key.lower(), a.lower()) == 1]
    return close[0] if close else None


def unknown_key(key: str, allowed, where: str) -> ConfigError:
    close = _suggest(key, allowed)
    hint = f"; did you mean {close!r}?" if close is not None else ""
    return ConfigError(
        f"unknown key {where}{show_value(key)}{hint} (allowed: {', '.join(map(str, allowed))})"
    )


def is_whole(x) -> bool:
    return isinstance(x, (int, np.integer)) and not isinstance(x, bool)


def _is_real(x) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool)


def as_int(value, key: str, *, minimum: int | None = None, maximum: int | None = None,
         allowed: str | None = None) -> int:
    """``value`` as an int: an integer, or a float with an integral value (``2.0e3``).

    ``allowed`` describes the range in the type error (default: from the bounds)."""
    name = key.rsplit('.', 1)[-1]
    if allowed is None:
        if minimum is not None and maximum is not None:
            allowed = f"allowed {minimum} <= {name} <= {maximum}"
        elif minimum is not None:
            allowed = f"allowed {name} >= {minimum}"
    kind = f"must be an integer; {allowed}" if allowed else "must be an integer"
    if isinstance(value, float) and value.is_integer() and abs(value) < 2**53:
        value = int(value)
    if maximum is not None and _is_real(value) and value > maximum:  # also 1e30, before int() of it
        low = f"{minimum} <= " if minimum is not None else ""
        raise ConfigError(f"{key} = {show_value(value)} is out of range; allowed {low}{name} <= {maximum}")
    if isinstance(value, float) and value.is_integer():  # beyond 2**53 a float is not exact
        raise ConfigError(f"{key} = {show_value(value)} {kind} (write it in digits: a float above 2**53 "
                          "is not an exact integer)")
    if not is_whole(value):
        raise ConfigError(f"{key} = {show_value(value)} {kind}")
    value = int(value)
    if minimum is not None and value < minimum:
        raise ConfigError(f"{key} = {value} must be an integer >= {minimum}")
    return value


def as_real(value, key: str, allowed: str | None = None) -> float:
    """``value`` as a finite float; ``allowed`` describes the range in the type error."""
    tail = f"; {allowed}" if allowed else ""
    if not _is_real(value):
        raise ConfigError(f"{key} = {show_value(value)} must be a number{tail}")
    try:
        value = float(value)
    except OverflowError:  # an int beyond float range
        raise ConfigError(f"{key} = {show_value(value)} must be a finite number{tail}") from None
    if not math.isfinite(value):
        raise ConfigError(f"{key} = {value!r} must be a finite number{tail}")
    return value
