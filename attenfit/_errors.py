"""The exceptions attenfit raises for bad input.

Every error a user can cause is a subclass of `AttenfitError` and of one builtin
(`ValueError`, `TypeError` or `KeyError`), so `except ValueError` keeps working.
Messages are one line that names the bad value and says what is allowed.
"""

from __future__ import annotations

__all__ = [
    "AttenfitError",
    "BadTypeError",
    "BadValueError",
    "DataFileError",
    "OutputExistsError",
    "UnknownNameError",
]


class AttenfitError(Exception):
    """Base class of every error caused by bad input to attenfit."""


class BadValueError(AttenfitError, ValueError):
    """A value is out of its allowed range or shape (NaN, negative radius, ...)."""


class BadTypeError(AttenfitError, TypeError):
    """A value has the wrong type or dtype (a string for a radius, a complex array, ...)."""


class UnknownNameError(AttenfitError, KeyError):
    """A name (family, solver, loss, emitter, ...) is not one attenfit knows."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""


class OutputExistsError(BadValueError):
    """An output exists already and overwriting it was not asked for (`force=True`).

    `what` says what exists, `action` what forcing would do ("overwrite it"); the message
    names the API's remedy (`force=True`), `cli_message()` the command line's (`--force`).
    """

    def __init__(self, what: str, action: str = "replace it"):
        self.what, self.action = what, action
        super().__init__(f"{what}; pass force=True to {action}")

    def cli_message(self) -> str:
        """The message with the command line's remedy."""
        return f"{self.what}; use --force to {self.action}"


class DataFileError(BadValueError):
    """A file is missing, unreadable, truncated, corrupt or not attenfit's."""
