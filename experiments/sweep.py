"""Sweeps: many independent training runs or evaluations, spread over local processes or Ray.

    python -m experiments.sweep --layout two-room,three-room --horizon myopic,anticipatory --seed 0-2 [--steps N] --workers 2
    python -m experiments.sweep --kind guided --layout two-room --checkpoint CKPT --beta 1,1.25,1.5 --budget 1000,5000 --sequences 1,3,6 --ray

--kind train (the default): one `learning.dqn` run per point of the grid layouts × horizons ×
seeds × any other training setting given as a list (`--gamma 0.95,0.97`; every
`learning.dqn` flag is accepted, a single value applies to all runs; a discount other than Table A.2's
is named even alone, as in a list). Each run is a
work item: it trains in RUNS/<PDDL domain name>-<layout>-<horizon>-seed<seed>[-<setting><value>...]
(resuming from its last.pt, as `learning.dqn` does) and its outcome (steps, tasks, best greedy
evaluation, last metrics row) goes to OUT.parts/<run>.json, with its provenance, as soon as
it ends; a part of the same settings is reused on a rerun (delete it to train again). Every
point's settings, and every file name made of them, are checked before anything is written.
On a multi-node cluster RUNS must be on a shared filesystem, since the runs write there.
With --seeds-together the runs that differ only in their seed are one work item, trained in one
process with their updates batched (`learning.q.seeds`, as `learning.dqn --seed 0,4,8,16`).
With --deploy, a finished run is also exported (`learning.export`: the float16 checkpoint
CHECKPOINTS/rl-<horizon>-<layout>-seed<seed>[-<setting><value>...].pt and RESULTS/training-....json)
and evaluated greedily on the canonical sequences (`rl-greedy`, RESULTS/rl-greedy-....json):
what Table A.4's greedy rows need, per seed, in one command:

    python -m experiments.sweep --layout two-room --horizon myopic,anticipatory --seed 0,4,8,16 --runs runs/dqn --deploy

--kind guided: the rl-guided agent (the value-guided Bellman–Novelty search) on the
canonical sequences (default: the development split 1,3,6) for every β × budget × depth cap; each (setting, sequence) is a work
item, each setting's results file goes to RESULTS (`experiments.workers`: identical to
`python -m experiments.evaluate --agent rl-guided ...` run serially).

OUT (default guided: results/sweeps/guided-<checkpoint name>.json; train: named after the grid,
results/sweeps/train-<domain>-<layouts>-<horizons>-seed<seeds>[-<setting><values>].json) lists every point with its
figures, the wall time, the summed item times and how the items ran. --workers N: N local
processes (default 1: serially, here); --ray: Ray tasks (plain tasks, not Ray Tune) on a
local instance, or on the cluster at RAY_ADDRESS.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import re
import sys
import time
from pathlib import Path

from oracles.command import reference_path
from oracles.myopic import PLANNERS
from planning import cli
from planning.atomic import write_json
from planning.domain.compiler import compile_domain
from planning.errors import DomainError
from planning.parallel import describe, one_thread, provenance, run_items
from planning.world.results import default_out, file_prefix
from planning.world.runner import evaluate

from .registry import agent_class, agent_options
from .workers import Job, play_over_workers

GRID = ("layout", "horizon", "seed")  # the axes every training sweep has
NAMED_ALONE = ("gamma",)  # settings a run's names carry even when given one value, where it is not Table A.2's
TIMING_KEYS = ("steps_per_s", "updates_per_s")  # left out of the outcome: they differ run to run


# ---- lists on the command line -------------------------------------------------------------
def _values(text: str, kind, name: str) -> list:
    """'0-2' -> [0, 1, 2] (integers), '1,1.5' -> [1.0, 1.5]; a single value -> [value]."""
    out = []
    for part in str(text).split(","):
        part = part.strip()
        try:
            if kind is int and re.fullmatch(r"\d+-\d+", part):
                lo, hi = part.split("-")
                out += list(range(int(lo), int(hi) + 1))
            elif kind is bool:
                out.append(part.lower() in ("1", "true", "yes"))
            else:
                out.append(kind(part))
        except ValueError:
            raise DomainError(
                f"--{name.replace('_', '-')}", f"'{text}' is not a list of {kind.__name__} values"
            ) from None
    return out


def summary_name(domain: str, grid: dict) -> str:
    """train-<domain>-<layouts>-<horizons>-seed<seeds>[-<setting><values>...]: a training sweep's default
    summary, named after its grid, so that two sweeps of one domain keep their own. Values are joined
    by '+', runs of consecutive integers written a-b (seed 0-3+8)."""

    def spell(values):
        runs = []
        for v in values:
            if isinstance(v, int) and runs and isinstance(runs[-1][1], int) and v == runs[-1][1] + 1:
                runs[-1][1] = v
            else:
                runs.append([v, v])
        return "+".join(str(a) if a == b else f"{a}-{b}" for a, b in runs)

    return "-".join(
        [
            "train",
            domain,
            *(spell(v) if axis in ("layout", "horizon") else f"{axis}{spell(v)}" for axis, v in grid.items()),
        ]
    )


def _field_kind(f) -> type:
    t = str(f.type)
    return int if t.startswith("int") else float if t.startswith("float") else bool if t == "bool" else str


# ---- training runs -------------------------------------------------------------------------
def item_config(item: dict):
    """A training item's settings, built and checked as learning.dqn builds its own (`learning.q.training.make_config`)."""
    from learning.q.training import make_config

    return make_config(
        item["domain"], item["layout"], item["horizon"], seed=item["seed"], out=item["out"], **item["settings"]
    )


def train_item(item: dict) -> dict:
    """One learning.dqn run to the end, started or resumed as learning.dqn does (`learning.q.training.train_run`:
    the run folder locked, metrics rows past the resumed checkpoint dropped); its outcome."""
    from learning.q.training import train_run

    return outcome(item, train_run(item_config(item), progress=False))


def train_group(items: list) -> list:
    """Runs that differ only in their seed, trained together in one process (`learning.q.training.train_runs`,
    `--seeds-together`); their outcomes, in order."""
    from learning.q.training import train_runs

    trainers = train_runs([item_config(item) for item in items], progress=False)
    return [outcome(item, trainer) for item, trainer in zip(items, trainers)]


def seed_groups(todo: list) -> list:
    """The (name, item) pairs to train, grouped by every setting but the seed (`--seeds-together`)."""
    groups: dict = {}
    for name, item in todo:
        key = json.dumps({k: v for k, v in item.items() if k not in ("seed", "out", "deploy")}, sort_keys=True)
        groups.setdefault(key, []).append((name, item))
    return list(groups.values())


def outcome(item: dict, trainer) -> dict:
    """What a sweep records of a finished training run (and, with --deploy, its export and greedy figures)."""
    from learning.q.training import last_row

    cfg = trainer.cfg
    out = {
        "run": item["out"],
        "config": dataclasses.asdict(cfg),
        "steps": trainer.step,
        "tasks": trainer.tasks_done,
        "best": trainer.best,
        "last": {k: v for k, v in last_row(trainer.metrics).items() if k not in TIMING_KEYS},
    }
    if item.get("deploy"):
        out["deployed"] = deploy(trainer.model, Path(item["out"]), item["deploy"])
    return out


def deploy(model, run: Path, paths: dict) -> dict:
    """Export a finished run (compact checkpoint, key figures) and play its greedy policy on the
    sequences; the greedy figures and where everything went."""
    from learning.export import export

    export(run, Path(paths["checkpoint"]), Path(paths["figures"]), force=paths.get("force", False))
    agent = agent_class("rl-greedy").from_args(agent_options("rl-greedy", checkpoint=paths["checkpoint"]), model)
    r = evaluate(model, agent, paths["sequences"], paths["greedy"], progress=False, reference=reference_path(model))
    return {
        **paths,
        **{k: r[k] for k in ("cost_per_task", "success_rate", "actions_per_task", "improvement_vs_myopic")},
    }


def train_items(args, grid: dict, settings: dict) -> tuple[list, list, list]:
    """(points, run names, work items) of a training grid, every point's settings checked as learning.dqn
    checks its own and every name made from them checked to name a file in its folder: a bad value
    (`--eps-schedule ../../x`) stops with a one-line error before anything is written."""
    from learning.export import rl_name
    from learning.q.training import Config, file_in, file_name, run_name

    axes = list(grid)
    points = [dict(zip(axes, combo)) for combo in itertools.product(*grid.values())]
    varied = [a for a in axes if a not in GRID and len(grid[a]) > 1]
    # a discount given alone is named as in a list of them: `--gamma 0.9` trains where `--gamma 0.9,0.99` puts
    # its γ = 0.9 runs (Table A.5's names), not into the default run's folder under the default's file names
    alone = [a for a in NAMED_ALONE if a in settings and settings[a] != getattr(Config, a)]
    pddl_names = {}  # layout -> the PDDL domain's name, which learning.dqn and learning.export name files after
    items, names = [], []
    for p in points:
        # a run with a target bound keeps its files apart under learning.dqn's own suffix
        extra = "".join(f"-{a}{p[a]}" for a in varied if a != "target_bound")
        extra += "".join(f"-{a}{settings[a]}" for a in alone)
        item = {
            "domain": args.domain,
            "layout": p["layout"],
            "horizon": p["horizon"],
            "seed": p["seed"],
            "settings": {**settings, **{a: p[a] for a in axes if a not in GRID}},
            "out": None,
        }
        # named from the settings the run will have (domain.toml [training] included, a setting no run can
        # have refused here), as learning.dqn and learning.export name it: a domain's default task encoding
        # is in the names, and a run of another encoding never shares its folder or files
        effective = {**dataclasses.asdict(item_config(item)), **p}
        if p["layout"] not in pddl_names:
            model = compile_domain(args.domain, p["layout"])
            pddl_names[p["layout"]] = file_name(model.name, model.files["domain"], "domain name")
        pddl = pddl_names[p["layout"]]
        name = run_name(pddl, effective, extra)
        items.append({**item, "out": str(Path(args.runs) / name)})
        for axis in grid:
            file_name(p[axis], f"--{axis.replace('_', '-')}", "value")
        file_in(args.runs, name, "--runs", "a run folder's name")
        if args.deploy:  # learning.export's and experiments.evaluate's default names
            short = rl_name(effective, extra)
            first = file_prefix(pddl)
            items[-1]["deploy"] = {
                "checkpoint": f"{args.checkpoints}/{first}rl-{short}.pt",
                "figures": f"{args.results}/{first}training-{short}.json",
                "greedy": f"{args.results}/{first}rl-greedy-{short}.json",
                "sequences": cli.parse_ids(args.sequences),
                **({"force": True} if args.force else {}),
            }
        names.append(name)
    return points, names, items


def train_sweep(args, grid: dict, settings: dict, plan: tuple, out: Path) -> dict:
    """Every point of `grid` (axis -> values) as a training run, `plan` its `train_items`; the merged outcome."""
    points, names, items = plan
    parts = Path(f"{out}.parts")
    results: dict = {}
    todo = []
    for name, item in zip(names, items):
        part = _load_part(parts / f"{name}.json")
        if part is not None and part.get("item") == item:
            results[name] = part
        else:
            todo.append((name, item))
    prov = provenance()

    def write_part(k, result, meta):
        name, item = todo[k]
        results[name] = {"item": item, "result": result, "provenance": {**prov, **meta}}
        write_json(parts / f"{name}.json", results[name])

    t0 = time.perf_counter()
    if args.seeds_together:  # one work item per group of seeds; each run's part written as its group ends
        groups = seed_groups(todo)
        at = {name: k for k, (name, _) in enumerate(todo)}

        def write_group(g, result, meta):
            for (name, _), r in zip(groups[g], result):
                write_part(at[name], r, meta)

        run_items(
            train_group,
            [[item for _, item in group] for group in groups],
            workers=args.workers,
            use_ray=args.ray,
            on_result=write_group,
            progress=not args.no_progress,
            desc="training runs (seeds together)",
        )
    else:
        run_items(
            train_item,
            [item for _, item in todo],
            workers=args.workers,
            use_ray=args.ray,
            on_result=write_part,
            progress=not args.no_progress,
            desc="training runs",
        )
    wall = time.perf_counter() - t0
    rows = []
    for name, p in zip(names, points):
        r = results[name]
        best = r["result"]["best"] or {}
        rows.append(
            {
                "name": name,
                **p,
                "run": r["result"]["run"],
                "steps": r["result"]["steps"],
                "tasks": r["result"]["tasks"],
                "best_step": best.get("step"),
                "best_eval": best.get("eval"),
                "last": r["result"]["last"],
                "seconds": r["provenance"].get("seconds"),
            }
        )
        if "deployed" in r["result"]:
            rows[-1]["greedy"] = r["result"]["deployed"]
    return {
        "kind": "train",
        "domain": Path(args.domain).resolve().name,
        "grid": grid,
        "settings": settings,
        "points": rows,
        "items_run": len(todo),
        "items_reused": len(items) - len(todo),
    }, wall


def _load_part(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text()) if path.is_file() else None
    except (OSError, ValueError):
        return None  # half a file: run again


# ---- rl-guided evaluations -----------------------------------------------------------------
def guided_sweep(args, layout: str, out: Path) -> tuple[dict, float]:
    """rl-guided on the sequences for every β × budget × depth cap; one results file per setting."""
    model = compile_domain(args.domain, layout)
    cls = agent_class("rl-guided")
    ids = cli.parse_ids(args.sequences)
    betas = _values(args.beta, float, "beta") if args.beta else [None]
    budgets = _values(args.budget, int, "budget") if args.budget else [None]
    depths = _values(args.depth_cap, int, "depth_cap") if args.depth_cap else [None]
    jobs = []
    for beta, budget, depth in itertools.product(betas, budgets, depths):
        options = agent_options(
            cls,
            checkpoint=args.checkpoint,
            beta=beta,
            budget=budget,
            depth_cap=depth,
            reference=args.reference,
            time_limit=args.time_limit,
        )
        agent = cls.from_args(options, model)
        jobs.append(
            Job(
                "rl-guided",
                options,
                args.domain,
                model,
                agent,
                ids,
                default_out(agent, model, args.results),
                args.force,
            )
        )
    t0 = time.perf_counter()
    played = play_over_workers(jobs, args.workers, args.ray, progress=not args.no_progress)
    wall = time.perf_counter() - t0
    rows = []
    for job in jobs:
        r = evaluate(model, job.agent, ids, job.out, progress=False, reference=reference_path(model), force=args.force)
        rows.append(
            {
                "beta": job.agent.beta,
                "budget": job.agent.budget,
                "depth_cap": job.agent.depth_cap,
                "cost_per_task": r["cost_per_task"],
                "success_rate": r["success_rate"],
                "actions_per_task": r["actions_per_task"],
                "improvement_vs_myopic": r["improvement_vs_myopic"],
                "file": job.out,
            }
        )
    return {
        "kind": "guided",
        "domain": model.name,
        "layout": model.layout,
        "checkpoint": args.checkpoint,
        "sequences": ids,
        "points": rows,
        "items_run": played["items"],
        "items_reused": played["reused"],
    }, wall


def main() -> None:
    one_thread()  # as in the workers: a serial sweep computes what a parallel one does
    from learning.q.training import Config, file_in, file_name

    p = cli.parser(
        __doc__.splitlines()[0],
        sequences=True,
        progress=True,
        workers=True,
        helps={"workers": "local processes (default: 1, serially here)"},
    )
    p.add_argument("--kind", choices=("train", "guided"), default="train", help="what to sweep (default: %(default)s)")
    p.add_argument(
        "--force",
        action="store_true",
        help="replace results files made otherwise (guided), exported "
        "checkpoints and figures of other runs (train --deploy)",
    )
    train = p.add_argument_group("--kind train (a comma list or range makes an axis of the grid)")
    train.add_argument("--horizon", default="myopic,anticipatory", help="(default: %(default)s)")
    train.add_argument("--runs", default="runs/sweep", help="folder of the run folders (default: %(default)s)")
    train.add_argument(
        "--deploy",
        action="store_true",
        help="export each finished run and evaluate it greedily on --sequences (default there: all)",
    )
    train.add_argument(
        "--seeds-together",
        action="store_true",
        help="train the seeds of each grid point in one process, their updates batched (learning.q.seeds): "
        "one work item per point",
    )
    train.add_argument(
        "--checkpoints",
        default="checkpoints",
        help="--deploy: folder of the compact checkpoints (default: %(default)s)",
    )
    docs = cli.field_docs(Config)
    for f in dataclasses.fields(Config):
        if f.name in ("domain", "layout", "horizon", "out"):
            continue
        default = "0" if f.name == "seed" else "domain.toml [training], else Table A.2"
        train.add_argument(
            f"--{f.name.replace('_', '-')}",
            dest=f.name,
            default=None,
            help=f"{docs.get(f.name, '')} (default: {default})".replace("%", "%%"),
        )
    guided = p.add_argument_group("--kind guided")
    guided.add_argument("--checkpoint", help="the Q-network checkpoint whose value guides the search")
    guided.add_argument("--beta", default=None, help="cost slacks, e.g. 1,1.25,1.5 (default: domain.toml [search])")
    guided.add_argument("--budget", default=None, help="expansions per task, e.g. 1000,5000")
    guided.add_argument("--depth-cap", default=None, help="depths of open nodes, e.g. 10,20")
    guided.add_argument("--reference", default="internal", choices=PLANNERS)
    guided.add_argument("--time-limit", type=float, default=60.0, help="reference planner seconds per task")
    p.add_argument(
        "--results",
        default=None,
        help="folder of the results files: guided, one per setting "
        "(default: results/sweeps); train --deploy (default: results)",
    )
    p.set_defaults(sequences=None)
    args = p.parse_args()
    if args.sequences is None:  # guided: the development split, as β was chosen; greedy: every sequence
        args.sequences = "1,3,6" if args.kind == "guided" else "0-9"
    if args.results is None:
        args.results = "results/sweeps" if args.kind == "guided" else "results"

    layouts = [x for x in (args.layout or "").split(",") if x] or [None]
    models = [compile_domain(args.domain, layout) for layout in layouts]  # an unknown layout stops here
    layouts = [m.layout for m in models]
    if args.kind == "guided":
        if not args.checkpoint:
            raise DomainError("--checkpoint", "--kind guided needs a checkpoint")
        if len(layouts) != 1:
            raise DomainError("--layout", "--kind guided sweeps one layout (its checkpoint's)")
        out = Path(args.out or f"results/sweeps/guided-{Path(args.checkpoint).stem}.json")
        result, wall = guided_sweep(args, layouts[0], out)
    else:
        grid = {
            "layout": layouts,
            "horizon": _values(args.horizon, str, "horizon"),
            "seed": _values(args.seed if args.seed is not None else "0", int, "seed"),
        }
        settings = {}
        for f in dataclasses.fields(Config):
            v = getattr(args, f.name, None)
            if f.name in ("domain", "layout", "horizon", "seed", "out") or v is None:
                continue
            values = _values(v, _field_kind(f), f.name)
            if len(values) > 1:
                grid[f.name] = values
            else:
                settings[f.name] = values[0]
        for h in grid["horizon"]:
            if h not in ("myopic", "anticipatory"):
                raise DomainError("--horizon", f"'{h}' is neither myopic nor anticipatory")
        plan = train_items(args, grid, settings)  # nothing is written before this
        domain = file_name(models[0].name, models[0].files["domain"], "domain name")
        out = Path(
            args.out
            or file_in("results/sweeps", f"{summary_name(domain, grid)}.json", "--out", "the default summary's name")
        )
        result, wall = train_sweep(args, grid, settings, plan, out)
    item_seconds = sum(pt.get("seconds") or 0 for pt in result["points"]) if args.kind == "train" else None
    result.update(wall_seconds=round(wall, 2), ran=describe(args.workers, args.ray), provenance=provenance())
    if item_seconds is not None:
        result["item_seconds"] = round(item_seconds, 2)
    write_json(out, result)
    print(
        f"{result['kind']} sweep: {len(result['points'])} points ({result['items_run']} items run, "
        f"{result['items_reused']} reused), {wall:.1f} s {result['ran']}; wrote {out}",
        file=sys.stdout,
    )


if __name__ == "__main__":
    cli.run(main)
