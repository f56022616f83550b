"""Errors with one-line messages that name the file or parameter and the problem."""


class SkelError(Exception):
    """Base of every error skelcore reports to a user; str(error) is one line."""


class InputError(SkelError):
    """The input file or cloud cannot be used."""


class ParameterError(SkelError):
    """A parameter value is out of its valid range."""


class SolverError(SkelError):
    """The linear solve of a contraction step failed."""
