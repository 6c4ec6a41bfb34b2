"""Exceptions raised by the mapper; messages name what was wrong and what is allowed."""


class MapperError(Exception):
    """Base class of every error the mapper raises."""


class InvalidParameterError(MapperError, ValueError):
    """A parameter is out of its allowed range; the message names the field and the range."""


class InvalidInputError(MapperError, ValueError):
    """An input array has the wrong shape or type; the message names the expected shape."""
