"""Canonical evaluation sequences: per layout, ten sequences of 50 tasks drawn i.i.d. from P.

Sequence i of a layout draws its tasks with seed TASK_SEED + i and re-samples
the world with reset seed RESET_SEED + i, so every agent sees exactly the same
tasks and the same starting world. They are generated once and stored as JSON
under domains/<name>/sequences/<layout>/seq-NN.json:

    python -m planning.world.sequences --domain domains/restaurant --layout two-room
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from planning import cli
from planning.atomic import write_json
from planning.domain.compiler import compile_domain
from planning.errors import DomainError
from planning.world.task_stream import draw_tasks

TASK_SEED, RESET_SEED = 1000, 2000
COUNT, LENGTH = 10, 50
DEVELOPMENT = (1, 3, 6)  # the split used to choose beta; the other seven are held out


@dataclass
class Sequence:
    id: int
    reset_seed: int
    tasks: list  # Task objects of the model


def sequence_dir(model) -> Path:
    return Path(model.folder) / "sequences" / model.layout


def generate(model, count: int = COUNT, length: int = LENGTH) -> list[dict]:
    """The canonical sequences of a layout, as the JSON records stored on disk."""
    return [
        {
            "id": i,
            "task_seed": TASK_SEED + i,
            "reset_seed": RESET_SEED + i,
            "split": "development" if i in DEVELOPMENT else "held-out",
            "tasks": [t.name for t in draw_tasks(model, TASK_SEED + i, length)],
        }
        for i in range(count)
    ]


def load(model, ids=None) -> list[Sequence]:
    """The stored sequences of the model's layout (all, or the given ids)."""
    folder = sequence_dir(model)
    files = sorted(folder.glob("seq-*.json"))
    if not files:
        raise DomainError(folder, "no canonical sequences (run: python -m planning.world.sequences)")
    out = []
    for path in files:
        try:
            rec = json.loads(path.read_text())
            if not isinstance(rec, dict) or not isinstance(rec.get("tasks"), list):
                raise TypeError("not an object with a list of tasks")
            seq = Sequence(int(rec["id"]), int(rec["reset_seed"]), [model.tasks.get(n) for n in rec["tasks"]])
        except DomainError as e:
            raise DomainError(path, e.reason) from None
        except (ValueError, KeyError, TypeError, UnicodeDecodeError) as e:
            raise DomainError(path, f"malformed sequence file ({type(e).__name__}: {e})") from None
        if ids is None or seq.id in ids:
            out.append(seq)
    missing = set(ids or []) - {s.id for s in out}
    if missing:
        raise DomainError(folder, f"no sequence with id {sorted(missing)}")
    return out


def main() -> None:
    p = cli.parser(__doc__.splitlines()[0])
    p.add_argument("--check", action="store_true", help="compare with the stored files instead of writing")
    args = p.parse_args()
    model = compile_domain(args.domain, args.layout)
    folder = sequence_dir(model)
    if not args.check:
        cli.check_writable(folder, folder=True)
    for rec in generate(model):
        path = folder / f"seq-{rec['id']:02d}.json"
        if args.check:
            if not path.is_file():
                raise DomainError(path, "missing (run without --check to write it)")
            try:
                stored = json.loads(path.read_text())
            except (json.JSONDecodeError, UnicodeDecodeError) as e:
                raise DomainError(path, f"malformed sequence file ({type(e).__name__}: {e})") from None
            if stored != rec:
                raise DomainError(path, "differs from the regenerated sequence")
        else:
            write_json(path, rec)
    print(f"{'checked' if args.check else 'wrote'} {COUNT} sequences of {LENGTH} tasks in {folder}")


if __name__ == "__main__":
    cli.run(main)
