"""The one exception shellrepair raises for bad input."""


class MeshError(ValueError):
    """Input that cannot be read or repaired.

    The message says what was wrong and where (file, line, element index).
    The CLI prints it as one line ``error: <file>: <message>`` and exits 2.

    Parameters
    ----------
    message : str
        What is wrong, in words a user can act on.
    path : str or None
        The file it concerns, if any.
    """

    def __init__(self, message, path=None):
        super().__init__(message)
        self.message = message
        self.path = None if path is None else str(path)

    def __str__(self):
        if self.path:
            return f"{self.path}: {self.message}"
        return self.message
