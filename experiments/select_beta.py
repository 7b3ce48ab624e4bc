"""Choose the search's cost slack β as the thesis did (Appendix A.1): the cheapest on the development sequences.

Evaluates the value-guided agent (`rl-guided`) with each β on the development
split (sequences 01, 03, 06), picks the β with the lowest cost per task (ties:
the smaller β), then plays the chosen β on all ten sequences and reports the
development and held-out splits separately, so the held-out figure is free of
the choice.

    python -m experiments.select_beta --layout three-room --checkpoint checkpoints/rl-anticipatory-three-room-seed0.pt [--betas 1.25,3,6,8]

Each evaluation is an ordinary results file under --results (resumable; the
default β's file is the agent's own, so its development sequences are reused
and extended, not replayed); the selection is written to OUT (default
results/beta-selection-<checkpoint>.json).
"""

from __future__ import annotations

from pathlib import Path

from learning.agents.guided import ValueGuidedPlanner
from oracles.command import reference_path
from planning import cli
from planning.atomic import write_json
from planning.domain.compiler import compile_domain
from planning.errors import DomainError
from planning.parallel import results_provenance
from planning.world.results import default_out, read
from planning.world.runner import evaluate, improvement
from planning.world.sequences import COUNT, DEVELOPMENT

THESIS_BETAS = (1.25, 3.0, 6.0, 8.0)


def split_costs(model, result: dict) -> dict:
    """Cost per task, success rate and improvement over the myopic oracle on the development and held-out splits."""
    out = {}
    for split, ids in (("development", set(DEVELOPMENT)), ("held-out", set(range(COUNT)) - set(DEVELOPMENT))):
        seqs = [s for s in result["per_sequence"] if s["id"] in ids]
        if not seqs:
            continue
        tasks = sum(s["tasks"] for s in seqs)
        cost = sum(s["cost"] for s in seqs) / tasks
        imp, why = improvement(cost, model, [s["id"] for s in seqs], reference_path(model))
        out[split] = {
            "sequences": [s["id"] for s in seqs],
            "tasks": tasks,
            "cost_per_task": round(cost, 2),
            "success_rate": round(sum(s["successes"] for s in seqs) / tasks, 4),
            "improvement_vs_myopic": imp,
            **({"improvement_note": why} if why else {}),
        }
    return out


def kept_apart(out: str, model, checkpoint: str, betas: list, budget) -> None:
    """A one-line error where `out` holds a finished selection made otherwise (another layout, checkpoint,
    budget or set of candidates): a finished results file is never replaced by a run with another
    configuration (pass --out)."""
    if not Path(out).is_file():
        return
    old = read(Path(out), "β selection")
    made = (
        old.get("layout"),
        old.get("checkpoint"),
        old.get("budget"),
        [c.get("beta") for c in old.get("candidates", [])],
    )
    if made != (model.layout, checkpoint, budget, betas):
        raise DomainError(
            out,
            f"holds the selection of layout {made[0]}, checkpoint {made[1]}, budget {made[2]}, β "
            f"{', '.join(f'{b:g}' for b in made[3])}; pass --out to keep both",
        )


def main() -> None:
    p = cli.parser(__doc__.splitlines()[0])
    p.add_argument("--checkpoint", required=True, help="Q-network checkpoint whose value guides the search")
    p.add_argument(
        "--betas", default=",".join(f"{b:g}" for b in THESIS_BETAS), help="candidate β (default: %(default)s)"
    )
    p.add_argument("--budget", type=int, default=None, help="expansions per task (default: domain.toml [search])")
    p.add_argument("--results", default="results", help="folder of the per-β results files (default: %(default)s)")
    p.add_argument("--no-final", action="store_true", help="stop after choosing; do not play all ten sequences")
    args = p.parse_args()
    try:
        betas = [float(b) for b in args.betas.split(",")]
    except ValueError:
        raise DomainError("--betas", f"'{args.betas}' is not a comma-separated list of numbers") from None
    model = compile_domain(args.domain, args.layout)
    out = args.out or f"results/beta-selection-{Path(args.checkpoint).stem}.json"
    kept_apart(out, model, args.checkpoint, betas, args.budget)
    rows = []
    for beta in betas:
        agent = ValueGuidedPlanner(model, args.checkpoint, beta=beta, budget=args.budget)
        path = default_out(agent, model, args.results)
        r = evaluate(model, agent, list(DEVELOPMENT), path, reference=reference_path(model))
        dev = split_costs(model, r)["development"]  # a finished file may hold more sequences
        rows.append(
            {
                "beta": beta,
                **{k: dev[k] for k in ("cost_per_task", "success_rate", "improvement_vs_myopic")},
                "file": path,
            }
        )
        print(f"β = {beta:g}: development cost per task {dev['cost_per_task']}, success {dev['success_rate']}")
    best = min(rows, key=lambda r: (r["cost_per_task"], r["beta"]))
    result = {
        "domain": model.name,
        "layout": model.layout,
        "checkpoint": args.checkpoint,
        "budget": args.budget,
        "development": list(DEVELOPMENT),
        "candidates": rows,
        "chosen_beta": best["beta"],
    }
    print(f"chosen β = {best['beta']:g}")
    if not args.no_final:
        agent = ValueGuidedPlanner(model, args.checkpoint, beta=best["beta"], budget=args.budget)
        final = default_out(agent, model, args.results)
        r = evaluate(model, agent, list(range(COUNT)), final, reference=reference_path(model))
        result["final"] = {
            "file": final,
            "cost_per_task": r["cost_per_task"],
            "success_rate": r["success_rate"],
            "improvement_vs_myopic": r["improvement_vs_myopic"],
            "splits": split_costs(model, r),
        }
        for split, s in result["final"]["splits"].items():
            print(f"{split:12s} cost per task {s['cost_per_task']}, improvement vs myopic {s['improvement_vs_myopic']}")
    write_json(out, {**result, "provenance": results_provenance({"checkpoint": args.checkpoint})})
    print(f"wrote {out}")


if __name__ == "__main__":
    cli.run(main)
