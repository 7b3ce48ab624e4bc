"""Persistent oracle rollouts cached on disk: the one source of "states the myopic oracle visits".

Three consumers share it: the reward calibration (2,000 tasks, thesis §5.2.4),
the DQN's replay demonstrations (the first 500 task outcomes at seed 0,
Appendix A.1) and the GNN dataset generator (states along myopic plans).
The planner is the myopic oracle (`internal`, `fast-downward`) or the
clairvoyant one (`clairvoyant-K`: each task planned jointly with the next K-1
of the stream that come before the next world reset; only the first task's
plan is executed), the authors' planner for the anticipatory demonstrations.
`cached_rollout` returns the first n records of a seeded task stream; what a
cache file already holds is replayed (no planning), the rest is planned and
the file rewritten atomically every few tasks, so an interrupted run resumes.

One file per (domain, layout, planner, seed), e.g.
runs/rollouts/restaurant-two-room-internal-seed0.json. Plans are stored as
ground-action names with each record's task, reset seed, cost, success and
auto flag; states are rebuilt by replay on load and checked against them. A
file records the domain's identity (`planning.domain.identity`); one made from
other domain content (an edited action cost, task or layout) is not replayed
but planned again and replaced, as a cache is.

    python -m oracles.rollouts --layout two-room --tasks 2000 --seed 0 [--planner internal|clairvoyant-3]
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from tqdm import tqdm

from planning import cli
from planning.atomic import write_json
from planning.domain.compiler import compile_domain
from planning.domain.identity import identity, mismatch
from planning.errors import DomainError
from planning.world.agents import Planner, Reply

from .myopic import MyopicOracle, TaskRecord, rollout, type_table

FORMAT = 1  # bump when the file layout changes
SAVE_EVERY_SECONDS = 10.0  # a long planner call is never lost for more than this
SAVE_EVERY_TASKS = 50  # nor a run of quick ones
CLAIRVOYANT_SECONDS = 60.0  # a clairvoyant window's time limit (the clairvoyant evaluations'), then the myopic chain


def make_oracle(planner: str, time_limit: float) -> tuple[Planner, int]:
    """(the planner a rollout plays, how many upcoming tasks it is shown) for a planner name."""
    if planner.startswith("clairvoyant-"):
        from .clairvoyant import ClairvoyantOracle

        try:
            k = int(planner.removeprefix("clairvoyant-"))
        except ValueError:
            k = 0
        if k < 1:
            raise DomainError("--planner", f"'{planner}': clairvoyant-K needs a window K of at least 1")
        return ClairvoyantOracle(k, min(time_limit, CLAIRVOYANT_SECONDS)), k - 1
    if planner not in ("internal", "fast-downward"):
        raise DomainError("--planner", f"'{planner}' is not internal, fast-downward or clairvoyant-K")
    return MyopicOracle(planner, time_limit), 0


class RememberingOracle(Planner):
    """A planner that answers a (state, task, upcoming tasks) it has solved before with the same plan.

    A persistent rollout meets the same world and task again and again (on the
    canonical sequences ~25% of planned tasks, ~45% of the planning time), and
    the optimal planner is deterministic, so the answer is the one it would give.
    A clairvoyant plan also depends on the tasks it was shown (its info's window).
    """

    def __init__(self, planner: Planner):
        self.planner, self.name, self.config = planner, planner.name, planner.config
        self.plans: dict = {}

    def start(self, model, sequence) -> None:
        self.planner.start(model, sequence)

    def remember(self, rec: TaskRecord) -> None:
        """Keep a solved record's plan for its starting state and task."""
        if rec.success and rec.plan and not rec.auto:
            info = {k: v for k, v in rec.info.items() if k not in ("seconds", "remembered")}
            upcoming = tuple(rec.info.get("window", [rec.task])[1:])
            self.plans.setdefault((rec.states[0], rec.task, upcoming), (list(rec.plan), info))

    def plan(self, state: int, task, upcoming: list) -> Reply:
        known = self.plans.get((state, task.name, tuple(t.name for t in upcoming)))
        if known is not None:
            return Reply(list(known[0]), {**known[1], "remembered": True})
        return self.planner.plan(state, task, upcoming)


def cache_path(model, seed: int, planner: str = "internal", cache_dir="runs/rollouts") -> Path:
    """The cache file of one (domain, layout, planner, seed) rollout."""
    return Path(cache_dir) / f"{model.name}-{model.layout}-{planner}-seed{seed}.json"


def cached_rollout(
    model,
    seed: int,
    n_tasks: int,
    planner: str = "internal",
    time_limit: float = 600.0,
    cache_dir="runs/rollouts",
    progress=True,
) -> list[TaskRecord]:
    """The first n_tasks records of the seeded rollout of a planner, read from the cache and extended there."""
    if n_tasks < 0:
        raise DomainError("--tasks", f"{n_tasks} is not a number of tasks")
    path = cache_path(model, seed, planner, cache_dir)
    stored = load_records(model, path, seed, planner, stale="rebuild") if path.is_file() else []
    if len(stored) >= n_tasks:
        return replay(model, path, seed, stored[:n_tasks])
    inner, lookahead = make_oracle(planner, time_limit)
    oracle = RememberingOracle(inner)
    oracle.start(model, None)
    records: list[TaskRecord] = []
    bar = tqdm(total=n_tasks, desc=f"{planner} rollout {model.layout} seed {seed}", unit="task", disable=not progress)
    last_save, unsaved = time.monotonic(), 0
    gen = _checked(rollout(model, oracle, seed, n_tasks, done=stored, lookahead=lookahead), path, len(stored))
    start = time.perf_counter()
    for rec in gen:
        if rec.index < len(stored):
            _check_against(rec, stored[rec.index], path)
        else:
            rec.info["seconds"] = round(time.perf_counter() - start, 4)
            unsaved += 1
        oracle.remember(rec)
        records.append(rec)
        bar.update(1)
        if unsaved and (unsaved >= SAVE_EVERY_TASKS or time.monotonic() - last_save >= SAVE_EVERY_SECONDS):
            _save(model, path, seed, planner, oracle.config, records)
            last_save, unsaved = time.monotonic(), 0
        start = time.perf_counter()
    bar.close()
    if unsaved:
        _save(model, path, seed, planner, oracle.config, records)
    return records


def load_records(model, path, seed: int, planner: str, stale: str = "error") -> list[TaskRecord]:
    """The records a cache file holds, not yet replayed (states empty); a DomainError if it is unreadable.

    A file made from other content of the domain (its recorded digest differs) holds nothing for this
    one: `stale` "rebuild" reads it as empty (the caller plans the rollout again and replaces it),
    "error" makes it a one-line error."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise DomainError(path, f"corrupt rollout cache ({e}); delete it to recompute") from None
    if not isinstance(data, dict) or not isinstance(data.get("records"), list):
        raise DomainError(path, "corrupt rollout cache (no record list); delete it to recompute")
    want = {"format": FORMAT, "domain": model.name, "layout": model.layout, "planner": planner, "seed": seed}
    for key, value in want.items():
        if data.get(key) != value:
            raise DomainError(
                path, f"rollout cache has {key} {data.get(key)!r}, expected {value!r}; delete it to recompute"
            )
    diff = mismatch(data, model)
    if diff is not None:
        if stale == "rebuild":
            return []
        raise DomainError(path, f"a rollout cache made from {diff}; delete it to recompute")
    out = []
    for i, r in enumerate(data["records"]):
        try:
            plan = [model.action(name) for name in r["plan"]]
            out.append(
                TaskRecord(
                    i,
                    r["task"],
                    r["reset_seed"],
                    [],
                    plan,
                    int(r["cost"]),
                    bool(r["success"]),
                    bool(r["auto"]),
                    -1,
                    dict(r.get("info", {})),
                )
            )
        except DomainError as e:
            raise DomainError(path, f"record {i}: {e}; delete it to recompute") from None
        except (KeyError, TypeError, ValueError, AttributeError) as e:
            raise DomainError(path, f"record {i} is malformed ({e!r}); delete it to recompute") from None
    return out


def replay(model, path, seed: int, stored: list[TaskRecord]) -> list[TaskRecord]:
    """Stored records with their states rebuilt by replaying their plans on the seeded stream, checked."""
    records = []
    for rec in _checked(rollout(model, None, seed, len(stored), done=stored), path, len(stored)):
        _check_against(rec, stored[rec.index], path)
        records.append(rec)
    return records


def _checked(records, path, n_stored: int):
    """Re-raise a failure replaying the first n_stored records (another task drawn, an inapplicable
    action) as an error naming the cache; errors while planning later tasks pass through."""
    yielded = 0
    try:
        for rec in records:
            yielded += 1
            yield rec
    except (ValueError, DomainError) as e:
        if yielded >= n_stored:
            raise
        raise DomainError(path, f"does not replay ({e}); delete it to recompute") from None


def _check_against(rec: TaskRecord, want: TaskRecord, path) -> None:
    """A replayed record must end as the stored one did."""
    got = (rec.task, rec.reset_seed, rec.cost, rec.success, rec.auto, rec.plan)
    exp = (want.task, want.reset_seed, want.cost, want.success, want.auto, want.plan)
    if got != exp:
        fields = ("task", "reset_seed", "cost", "success", "auto", "plan")
        bad = next(f"{f} {g!r} on replay, {e!r} stored" for f, g, e in zip(fields, got, exp) if g != e)
        raise DomainError(path, f"record {rec.index} ({want.task}) does not replay: {bad}; delete it to recompute")
    rec.info = dict(want.info)


def _save(model, path: Path, seed: int, planner: str, config: dict, records: list[TaskRecord]) -> None:
    # Another process extending the same cache may already have written more; keep the longer file
    # (if it is of this domain content: a stale one is replaced).
    mine = identity(model)
    if path.is_file():
        try:
            there = json.loads(path.read_text())
            if there.get("domain_sha256") == mine["domain_sha256"] and len(there.get("records", [])) > len(records):
                return
        except (OSError, ValueError, AttributeError):
            pass
    write_json(
        path,
        {
            "format": FORMAT,
            **mine,
            "layout": model.layout,
            "planner": planner,
            "seed": seed,
            "config": config,
            "tasks": len(records),
            "records": [
                {
                    "task": r.task,
                    "reset_seed": r.reset_seed,
                    "plan": [model.actions[a] for a in r.plan],
                    "cost": r.cost,
                    "success": r.success,
                    "auto": r.auto,
                    "info": r.info,
                }
                for r in records
            ],
        },
    )


def rows(model, records: list[TaskRecord]) -> list[dict]:
    """Per-task rows shaped like the evaluation runner's (for type_table)."""
    return [
        {
            "index": r.index,
            "task": r.task,
            "cost": r.cost,
            "actions": len(r.plan),
            "success": r.success,
            "auto": r.auto,
            "seconds": r.info.get("seconds", 0.0),
        }
        for r in records
    ]


def record_states(records) -> list[int]:
    """The worlds a rollout passes through: fresh worlds, states along each plan, post-consumption worlds."""
    out = []
    for i, rec in enumerate(records):
        if i == 0 or rec.reset_seed is not None:
            out.append(rec.states[0])
        out += rec.states[1:-1]
        out.append(rec.after)
    return out


def faithful_states(model, n: int, seed: int = 0, progress: bool = True) -> list[int]:
    """n distinct states visited by the myopic oracle (oracles.rollouts.cached_rollout, planner internal)."""
    n_tasks = max(8, n // 4)
    while True:
        records = cached_rollout(model, seed, n_tasks, progress=progress)
        states = list(dict.fromkeys(record_states(records)))
        if len(states) >= n:
            return states[:n]
        n_tasks = int(n_tasks * 1.5) + 1


def main() -> None:
    p = cli.parser(__doc__.splitlines()[0], seed=True)
    p.add_argument("--tasks", type=int, default=2000, help="tasks of the stream (default: %(default)s)")
    p.add_argument(
        "--planner", default="internal", help="internal, fast-downward or clairvoyant-K (default: %(default)s)"
    )
    p.add_argument("--time-limit", type=float, default=600.0, help="planner seconds per task (default 600)")
    p.add_argument("--cache-dir", default="runs/rollouts", help="where caches live (default: %(default)s)")
    args = p.parse_args()
    model = compile_domain(args.domain, args.layout)
    start = time.perf_counter()
    records = cached_rollout(model, args.seed, args.tasks, args.planner, args.time_limit, args.cache_dir)
    table = rows(model, records)
    n = max(len(table), 1)
    print(
        f"\nrollout ({args.planner}), {model.name} {model.layout}, seed {args.seed}: "
        f"{len(table)} tasks, cost per task {sum(r['cost'] for r in table) / n:.1f}, "
        f"{time.perf_counter() - start:.1f}s this run"
    )
    if table:
        print(type_table({"per_task": table}))
    print(f"wrote {cache_path(model, args.seed, args.planner, args.cache_dir)}")
    if args.out:
        write_json(
            args.out,
            {
                **identity(model),
                "layout": model.layout,
                "planner": args.planner,
                "seed": args.seed,
                "tasks": len(table),
                "cost_per_task": round(sum(r["cost"] for r in table) / n, 2),
                "per_task": table,
            },
        )
        print(f"wrote {args.out}")


if __name__ == "__main__":
    cli.run(main)
