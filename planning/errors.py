"""The one error type of the toolkit: a one-line message naming the file or thing and the reason."""


class DomainError(Exception):
    """Bad input: a malformed file, an undefined cost, an unknown name, an inapplicable action."""

    def __init__(self, where, reason: str):
        super().__init__(f"{where}: {reason}")
        self.where = str(where)
        self.reason = reason
