"""Benchmarks: each module here exposes `main(argv) -> int`; `--json` prints one JSON object last."""
import pkgutil


def available():
    return sorted(m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_"))
