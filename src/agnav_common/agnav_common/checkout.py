"""Where the agnav source checkout is, for the bundled bags and docs: $AGNAV_ROOT, else the folder above a file that
holds bags/ and src/agnav_bringup/ (an editable or --symlink-install), else None (a plain installed copy)."""
import os
from pathlib import Path


def find_checkout(start: Path) -> Path | None:
    """The agnav checkout holding `start`, else None."""
    for d in [start, *start.parents]:
        if (d / "bags").is_dir() and (d / "src" / "agnav_bringup").is_dir():
            return d
    return None


def checkout_root(here: Path) -> Path:
    """$AGNAV_ROOT, the checkout holding `here`, else the current directory (relative paths are the user's)."""
    env = os.environ.get("AGNAV_ROOT")
    return Path(env) if env else (find_checkout(here.resolve()) or Path.cwd())
