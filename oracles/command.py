"""The command line every evaluation shares: --force and --strict, the results file, the window log, the run.

The oracles' own commands and `experiments.evaluate` play an agent the same
way: the results file defaults to the agent's run name, an agent that keeps a
window log writes it beside the results, and the improvement is measured
against the myopic oracle's results file of the layout.
"""
from __future__ import annotations

from planning import cli
from planning.world.runner import default_out, evaluate

REFERENCE = "results/myopic-oracle-{layout}.json"
"""The myopic oracle's results file (Fast Downward): every improvement figure is measured against it."""


def reference_path(model) -> str:
    """The myopic oracle's results file of a layout."""
    return REFERENCE.format(layout=model.layout)


def run_options(p) -> None:
    """--force, --strict and --no-progress, the options of every evaluation."""
    p.add_argument("--force", action="store_true", help="replace a finished results file made otherwise")
    p.add_argument("--strict", action="store_true", help="exit non-zero if any planner timed out or crashed")
    p.add_argument("--no-progress", action="store_true", help="no progress bars (logs of background runs)")


def play(model, agent, ids, args, before=None) -> tuple[dict, str]:
    """(results, results path) of the agent on the sequences; `before(out, log)` runs first (e.g. workers)."""
    out = args.out or default_out(agent, model)
    log = None
    if hasattr(agent, "set_log"):
        log = f"{out}.windows.jsonl"
        cli.check_writable(log)
        agent.set_log(log)
    if before is not None:
        before(out, log)
    return evaluate(model, agent, ids, out, reference=reference_path(model), force=args.force,
                    strict=args.strict, progress=not args.no_progress), out
