"""Benchmarks: each module here exposes `main(argv) -> int`; `--json` prints one JSON object last. Reports go
only where the command line says (`--write-docs PATH`); the checked-in ones are docs/benchmarks/*.md."""
import json
import pkgutil
from pathlib import Path


def available():
    return sorted(m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_"))


def docs_option(ap, name):
    """Add `--write-docs PATH` (the checked-in report: docs/benchmarks/NAME)."""
    ap.add_argument("--write-docs", metavar="PATH", type=Path,
                    help=f"write the markdown report to PATH (checked in: docs/benchmarks/{name})")


def write_docs(path, text):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


def report(args, text, result):
    """Print the markdown report, write it to --write-docs PATH if given, print the JSON object last if --json."""
    print(text)
    if args.write_docs:
        write_docs(args.write_docs, text)
    if args.json:
        print(json.dumps(result))
