"""Canonical evaluation sequences: per layout and task stream, ten sequences of 50 tasks.

Sequence i of a layout draws its tasks with seed TASK_SEED + i and re-samples
the world with reset seed RESET_SEED + i, so every agent sees exactly the same
tasks and the same starting world. The i.i.d. stream's (tasks drawn from P, the
thesis's protocol) are stored under domains/<name>/sequences/<layout>/seq-NN.json,
those of a stream declared in domain.toml ([streams.<name>], `planning.world.streams`)
under domains/<name>/sequences/<layout>/<stream>/seq-NN.json, with the same seeds:

    python -m planning.world.sequences --domain domains/restaurant --layout two-room [--stream NAME|all] [--check]
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from planning import cli
from planning.atomic import write_json
from planning.domain.compiler import compile_domain
from planning.errors import DomainError
from planning.world.streams import IID, stream, streams
from planning.world.task_stream import draw_tasks

TASK_SEED, RESET_SEED = 1000, 2000
COUNT, LENGTH = 10, 50
DEVELOPMENT = (1, 3, 6)  # the split used to choose beta; the other seven are held out


@dataclass
class Sequence:
    id: int
    reset_seed: int
    tasks: list  # Task objects of the model
    stream: str = IID  # the task stream it was drawn from (planning.world.streams)


def sequence_dir(model, stream_name: str | None = None) -> Path:
    """Where a layout's canonical sequences of a stream are stored (the i.i.d. stream's: the layout's folder)."""
    folder = Path(model.folder) / "sequences" / model.layout
    return folder if stream_name in (None, IID) else folder / stream_name


def generate(model, count: int = COUNT, length: int = LENGTH, stream_name: str | None = None) -> list[dict]:
    """The canonical sequences of a layout and stream, as the JSON records stored on disk (a declared
    stream's name their "stream")."""
    s = stream(model, stream_name)
    return [
        {
            "id": i,
            "task_seed": TASK_SEED + i,
            "reset_seed": RESET_SEED + i,
            "split": "development" if i in DEVELOPMENT else "held-out",
            **({} if s.kind == IID else {"stream": s.name}),
            "tasks": [t.name for t in draw_tasks(model, TASK_SEED + i, length, s)],
        }
        for i in range(count)
    ]


def load(model, ids=None, stream_name: str | None = None) -> list[Sequence]:
    """The stored sequences of the model's layout and stream (all, or the given ids)."""
    folder = sequence_dir(model, stream_name)
    files = sorted(folder.glob("seq-*.json"))
    if not files:
        hint = "" if stream_name in (None, IID) else f" --stream {stream_name}"
        raise DomainError(folder, f"no canonical sequences (run: python -m planning.world.sequences{hint})")
    out = []
    for path in files:
        try:
            rec = json.loads(path.read_text())
            if not isinstance(rec, dict) or not isinstance(rec.get("tasks"), list):
                raise TypeError("not an object with a list of tasks")
            seq = Sequence(
                int(rec["id"]),
                int(rec["reset_seed"]),
                [model.tasks.get(n) for n in rec["tasks"]],
                stream_name or IID,
            )
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
    p.add_argument(
        "--stream", default=IID, help="the task stream (domain.toml [streams.<name>]), or all (default: %(default)s)"
    )
    args = p.parse_args()
    model = compile_domain(args.domain, args.layout)
    names = list(streams(model)) if args.stream == "all" else [stream(model, args.stream).name]
    for name in names:
        folder = sequence_dir(model, name)
        if not args.check:
            cli.check_writable(folder, folder=True)
        for rec in generate(model, stream_name=name):
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
        s = stream(model, name)
        mix = (
            ""
            if s.kind == IID
            else ", its stationary type mix: " + ", ".join(f"{ty} {p:.3f}" for ty, p in zip(s.types, s.stationary()))
        )
        print(
            f"{'checked' if args.check else 'wrote'} {COUNT} sequences of {LENGTH} tasks in {folder} (stream {name}{mix})"
        )


if __name__ == "__main__":
    cli.run(main)
