"""Where the shared real data lives: ``$GPEXPLORE_DATA`` or ``../shared/data`` beside the repository."""

from __future__ import annotations

import os
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parents[1]


def shared_data_dir() -> Path | None:
    """The data folder, or None when neither ``$GPEXPLORE_DATA`` nor ``../shared/data`` exists.

    ``$GPEXPLORE_DATA``, when set, must name an existing folder.
    """
    env = os.environ.get("GPEXPLORE_DATA")
    if env:
        path = Path(env)
        if not path.is_dir():
            raise FileNotFoundError(f"GPEXPLORE_DATA={env} is not a folder")
        return path
    for base in (Path.cwd(), REPOSITORY):
        candidate = base.parent / "shared" / "data"
        if candidate.is_dir():
            return candidate
    return None
