"""The add-on's own exceptions."""


class StylizeError(ValueError):
    """A problem with the user's data or settings, reported to the user as it is."""


class Cancelled(Exception):
    """Raised inside a run when the user cancels it."""
