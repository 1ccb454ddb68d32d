"""Reading a text file whole, with one clear error naming the file when it cannot be read."""

from __future__ import annotations

from pathlib import Path


def read_text(path: Path, error: type[Exception]) -> str:
    """The UTF-8 text of ``path``; ``error`` (the reader's own error type) naming the file when
    it cannot be read or is not text."""
    try:
        return path.read_bytes().decode()
    except OSError as err:
        raise error(f"{path}: cannot read: {err.strerror or err}") from None
    except UnicodeDecodeError as err:
        raise error(f"{path}: not a text file (byte {err.start} is not UTF-8)") from None
