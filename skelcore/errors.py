"""Errors with one-line messages that name the file or parameter and the problem."""


class SkelError(Exception):
    """Base of every error skelcore reports to a user; str(error) is one line."""


class InputError(SkelError):
    """The input file or cloud cannot be used."""


class NonFiniteError(InputError):
    """Some points have NaN or Inf coordinates; `count` of `total` rows (loading may drop them on request)."""

    def __init__(self, message: str, count: int, total: int):
        super().__init__(message)
        self.count, self.total = count, total


class ParameterError(SkelError):
    """A parameter value is out of its valid range."""


class SolverError(SkelError):
    """The linear solve of a contraction step failed."""


class TooLargeError(InputError):
    """A cloud has more points than the cap or the memory budget allows; `voxel_size` brings it under."""

    def __init__(self, message: str, points: int, cap: int, voxel_size: float):
        super().__init__(message)
        self.points, self.cap, self.voxel_size = points, cap, voxel_size


class OutputError(SkelError):
    """A result cannot be written (full disk, no permission); files written before it are kept."""
