"""Reproduce the thesis's tables, figures and statistics from our results files, into one report.

    python -m experiments.reproduce [--layouts two-room,three-room] [--report-only] [--out docs/results.md]
    python -m experiments.reproduce --domain DIR [--layouts A,B] [--report-only] [--out FILE]

Without --report-only it first runs, through the agent registry and the
runner (`planning.world.runner.evaluate`: resumable, progress bars), every
evaluation a table row expects whose checkpoint exists and whose results file
does not (or is unfinished, or lacks sequences the row needs); runs another process
is writing, runs whose agent is not registered and runs without a checkpoint
are left, and listed with their commands. --discount-sweep also trains the
Table A.5 runs (long); --streams also plays the task-stream section's missing evaluations
(`experiments.report.streams`, on any domain: the internal myopic oracle, clairvoyant windows and the guided
agents whose checkpoints exist, per layout and stream; hours). Then, and alone with --report-only (well under a
minute), it writes the report (default docs/results.md) and its figures
(docs/figures/*.png beside it): `experiments.report.thesis`. The rows, files
and commands are in `experiments.report.specs`; which files are used and which
are flagged is `experiments.report.data`'s rule.

Any other domain folder (--domain; told apart by its PDDL define) gets the
report of `experiments.report.domain`: its own layouts (default: every layout
of the folder), the rows and tables that apply to any domain, and a list of
the thesis comparisons that do not, and the task-stream section where the
folder declares a stream ([streams.<name>]); default output docs/results-<domain>.md,
figures (a drifting stream's only) in docs/figures/. A layout without its canonical sequences is named with the command
that writes them, and none of its runs is played.
"""

from __future__ import annotations

import shlex
import subprocess
import sys
import time
from pathlib import Path

from tqdm import tqdm

from experiments.report import domain, thesis
from experiments.report.data import ALL, Context, load_run, run_protocol, writer_pid
from experiments.report.specs import DISCOUNT_TRAIN, LAYOUTS, RL_SEEDS, discount_runs
from experiments.report.specs import rows as row_specs
from planning import cli
from planning.atomic import read_json, write_json, write_text
from planning.errors import DomainError


# ---- running what is missing ----------------------------------------------------------------
def needs_run(loaded, ids=ALL) -> bool:
    """True if reproduce should (re)run this run: missing, interrupted (no process writing it), or used but
    short of the sequences `ids`. A file made otherwise (another configuration, failure protocol or domain
    content) is not used and not replaced: that takes the run's command with --force."""
    if loaded.status == "not run":
        return True
    if loaded.status == "in progress":
        return writer_pid(loaded.run) is None
    if not loaded.used:
        return False
    have = {s["id"] for s in loaded.data["per_sequence"]}
    return bool(set(ids) - have)


def run_missing(rows, ctx: Context, ids=ALL, progress: bool = True, via: str = "") -> list[str]:
    """Evaluate every run of `rows` that `needs_run`, the myopic oracles first; returns the files written.

    Each written file's provenance names the run's own `experiments.evaluate` command and `via` (this command).
    """
    from oracles.command import reference_path
    from planning.world.runner import evaluate

    todo = {run.out: run for row in rows for run in row.runs if needs_run(load_run(run, ctx), ids)}
    todo = sorted(todo.values(), key=lambda run: run.agent != "myopic-oracle")
    written = []
    for run in tqdm(todo, desc="runs", unit="run", disable=not progress):
        model, agent = ctx.model(run.layout), ctx.agent(run)
        if agent.keeps_log:
            agent.set_log(f"{run.out}.windows.jsonl")
        opts = list(run.options)
        stream = opts[opts.index("--stream") + 1] if "--stream" in opts else None
        evaluate(
            model,
            agent,
            list(ids),
            run.out,
            progress=progress,
            reference=reference_path(model, stream),
            protocol=run_protocol(run),
            stream=stream,
        )
        stamp(run, via)
        written.append(run.out)
    return written


def stamp(run, via: str) -> None:
    """Name the run's own command in its results file's provenance (the process was reproduce)."""
    data = read_json(run.out)
    prov = data.setdefault("provenance", {})
    prov.update(command=run.command, via=via)
    write_json(run.out, data)


def train_discount_sweep(progress: bool = True) -> None:
    """Table A.5's runs: train, export and greedily evaluate them (`specs.DISCOUNT_TRAIN`: every run resumes
    from its last.pt, a finished one is skipped), then the guided evaluation of each run that lacks it."""
    commands = [DISCOUNT_TRAIN, *(run.evaluate for run in discount_runs() if not Path(run.guided).is_file())]
    for command in commands:  # `python -m ...` lines, run with this interpreter
        print(command, file=sys.stderr)
        subprocess.run(
            [sys.executable, *shlex.split(command)[1:], *([] if progress else ["--no-progress"])], check=True
        )


# ---- the command --------------------------------------------------------------------------
def is_thesis_domain(ctx: Context) -> bool:
    """True for the restaurant (its PDDL define) with the thesis's layouts: the report of the thesis applies."""
    from planning.domain.folder import layouts as folder_layouts

    known = folder_layouts(ctx.domain)
    return set(LAYOUTS) <= set(known) and ctx.model(LAYOUTS[0]).name == "restaurant"


def playable(ctx: Context, layouts) -> list[str]:
    """The layouts whose canonical sequences exist (the others are named on stderr with their command)."""
    out = []
    for layout in layouts:
        folder = Path(ctx.domain) / "sequences" / layout
        if any(folder.glob("seq-*.json")):
            out.append(layout)
        else:
            print(
                f"{layout}: no canonical sequences in {folder}, nothing played (`python -m planning.world.sequences "
                f"--domain {ctx.domain} --layout {layout}` writes them)",
                file=sys.stderr,
            )
    return out


def main() -> None:
    p = cli.parser(
        __doc__.splitlines()[0],
        layout=False,
        progress=True,
        helps={"out": "report (default: docs/results.md; docs/results-<domain>.md for another domain)"},
    )
    p.add_argument(
        "--layouts",
        default=None,
        help="comma-separated layouts (default: the restaurant's "
        f"{','.join(LAYOUTS)}; every layout of another domain's folder)",
    )
    p.add_argument("--report-only", action="store_true", help="only read the results and write the report")
    p.add_argument("--discount-sweep", action="store_true", help="also train the Table A.5 runs (long)")
    p.add_argument(
        "--streams", action="store_true", help="also play the task-stream section's missing evaluations (hours)"
    )
    args = p.parse_args()
    ctx = Context(args.domain)
    restaurant = is_thesis_domain(ctx)
    if restaurant:
        known = list(LAYOUTS)
    else:
        from planning.domain.folder import layouts as folder_layouts

        known = folder_layouts(args.domain)
    layouts = [x for x in (args.layouts or ",".join(known)).split(",") if x]
    unknown = [x for x in layouts if x not in known]
    if unknown or not layouts:
        raise DomainError("--layouts", f"'{args.layouts}' names no known layout (known: {', '.join(known)})")
    if args.discount_sweep and not restaurant:
        raise DomainError("--discount-sweep", f"trains the restaurant's Table A.5 runs, not {args.domain}'s")
    command = " ".join(["python -m experiments.reproduce", *map(shlex.quote, sys.argv[1:])])
    if not args.report_only:
        from planning.parallel import one_thread

        one_thread()
        rows = (
            [r for layout in layouts for r in row_specs(layout)]
            if restaurant
            else [r for layout in playable(ctx, layouts) for r in domain.rows(ctx, layout)]
        )
        written = run_missing(rows, ctx, progress=not args.no_progress, via=command)
        print(f"ran {len(written)} evaluations", file=sys.stderr)
        if args.streams:
            from experiments.report import streams

            seeds = RL_SEEDS.__getitem__ if restaurant else None  # Appendix A.1's, or those trained
            extra = [row for rows in streams.load_specs(ctx, playable(ctx, layouts), seeds) for row in rows]
            written = run_missing(extra, ctx, progress=not args.no_progress, via=command)
            print(f"ran {len(written)} task-stream evaluations", file=sys.stderr)
        if args.discount_sweep:
            train_discount_sweep(not args.no_progress)
    start = time.perf_counter()
    if restaurant:
        out = Path(args.out or "docs/results.md")
        write_text(out, thesis.report(layouts, ctx, out, command))
        print(f"wrote {out} and its figures in {time.perf_counter() - start:.1f} s")
    else:
        out = Path(args.out or f"docs/results-{ctx.model(layouts[0]).name}.md")
        write_text(out, domain.report(layouts, ctx, command, out.parent / "figures"))
        print(f"wrote {out} in {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    cli.run(main)
