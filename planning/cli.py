"""The command-line contract shared by every tool (SPEC.md): --domain, --layout, --sequences, --seed, --out."""
from __future__ import annotations

import argparse
import sys

from .errors import DomainError


def parser(description: str, sequences: bool = False) -> argparse.ArgumentParser:
    """An argument parser with the common options."""
    p = argparse.ArgumentParser(description=description)
    p.add_argument("--domain", default="domains/restaurant", help="domain folder (default: %(default)s)")
    p.add_argument("--layout", default=None, help="layout name (default: the folder's first)")
    if sequences:
        p.add_argument("--sequences", default="0-9", help="canonical sequences, e.g. 0-9 or 1,3,6")
    p.add_argument("--seed", type=int, default=0, help="random seed (default: %(default)s)")
    p.add_argument("--out", default=None, help="results JSON to write")
    return p


def parse_ids(text: str) -> list[int]:
    """'0-9' -> [0..9]; '1,3,6' -> [1, 3, 6]."""
    ids = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        try:
            ids += list(range(int(lo), int(hi) + 1)) if hi else [int(lo)]
        except ValueError:
            raise DomainError("--sequences", f"'{text}' is not a list like 0-9 or 1,3,6") from None
    return ids


def run(main) -> None:
    """Call main(); bad input ends with one line on stderr and exit status 2."""
    try:
        main()
    except DomainError as e:
        print(f"error: {e}", file=sys.stderr)
        sys.exit(2)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        sys.exit(130)
