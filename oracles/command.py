"""The command line every evaluation shares: --force, --strict, the failure protocol, the results file, the run.

The oracles' own commands and `experiments.evaluate` play an agent the same
way: the results file defaults to the agent's run name, an agent that keeps a
window log writes it beside the results, and the improvement is measured
against the myopic oracle's results file of the layout. What a command prints
is computed from the rows of the sequences it was asked for, and says whether
it played them now or kept them from a finished file.
"""

from __future__ import annotations

from dataclasses import dataclass

from planning import cli
from planning.world.results import DEFAULT_PROTOCOL, FAILURE_PROTOCOLS, default_out, file_prefix
from planning.world.runner import evaluate
from planning.world.streams import stream

REFERENCE = "results/myopic-oracle-{layout}.json"
"""The myopic oracle's results file (Fast Downward): every improvement figure is measured against it."""


def reference_path(model, stream: str | None = None) -> str:
    """The myopic oracle's results file of a layout (its name carries the domain's, but for the restaurant) on
    the canonical sequences of a stream (None or iid: the i.i.d. ones; another: its name ends -stream-<name>)."""
    path = REFERENCE.format(layout=model.layout)
    if stream not in (None, "iid"):
        path = path.replace(".json", f"-stream-{stream}.json")
    return path.replace("results/", f"results/{file_prefix(model.name)}", 1)


@dataclass(frozen=True)
class RunOptions:
    """How an evaluation plays and writes its results: the flags `run_options` declares, --out and --no-progress."""

    out: str | None = None
    """the results file (None: the agent's default, `planning.world.results.default_out`)"""
    force: bool = False
    """play every sequence asked for again, replacing a finished results file made otherwise"""
    strict: bool = False
    """a planner timeout or crash is an error once the results are written"""
    failure_protocol: str = DEFAULT_PROTOCOL
    """how a failed task is accounted for (`planning.world.results.FAILURE_PROTOCOLS`)"""
    progress: bool = True
    """progress bars"""
    stream: str = "iid"
    """the task stream whose canonical sequences are played (`planning.world.streams`)"""

    @classmethod
    def from_args(cls, args) -> "RunOptions":
        """The options of a parsed command line (`planning.cli.parser` with `progress`, and `run_options`)."""
        return cls(
            args.out,
            args.force,
            args.strict,
            args.failure_protocol,
            not args.no_progress,
            getattr(args, "stream", "iid"),
        )


def run_options(p) -> None:
    """--force, --strict and --failure-protocol, the options of every evaluation (`RunOptions`) beside the
    shared --out and --no-progress of its `planning.cli.parser`."""
    p.add_argument(
        "--force",
        action="store_true",
        help="play every sequence asked for again, replacing a finished results file (even one made otherwise)",
    )
    p.add_argument("--strict", action="store_true", help="exit non-zero if any planner timed out or crashed")
    p.add_argument(
        "--failure-protocol",
        default=DEFAULT_PROTOCOL,
        choices=list(FAILURE_PROTOCOLS),
        help="a failed task is completed by the optimal fallback, which is executed (default, SPEC.md), "
        "or abandoned where it stopped (the thesis's protocol; no improvement unless every task "
        "succeeds)",
    )
    p.add_argument(
        "--stream",
        default="iid",
        help="play the canonical sequences of this task stream (domain.toml [streams.<name>]; default: %(default)s, "
        "the thesis's); the results file's name ends in -stream-<name>",
    )


def play(model, agent, ids, options: RunOptions, before=None):
    """(results, results path) of the agent on the sequences; `before(out, log)` runs first (e.g. workers)
    and returns the sequences it played, if any. The results are a `planning.world.runner.Evaluation`."""
    protocol = options.failure_protocol
    if options.stream != "iid":
        stream(model, options.stream)  # an unknown stream stops here, naming the known ones
        agent.on_stream(options.stream)
    out = options.out or default_out(agent, model, protocol=protocol)
    log = None
    if agent.keeps_log:
        log = f"{out}.windows.jsonl"
        cli.check_writable(log)
        agent.set_log(log)
    elsewhere = {}
    if before is not None:
        elsewhere = before(out, log) or {}
    r = evaluate(
        model,
        agent,
        ids,
        out,
        reference=reference_path(model, options.stream),
        force=options.force,
        strict=options.strict,
        progress=options.progress,
        protocol=protocol,
        played_by_workers=elsewhere.get("played", ()),
        stream=options.stream,
    )
    r.seconds = round(r.seconds + elsewhere.get("wall", 0.0), 1)
    return r, out


def what_ran(r) -> str:
    """One line: the sequences played now and how long they took, or that the file was kept as it was."""
    if r.played:
        verb = "wrote" if r.wrote else "played"
        return f"played sequences {cli.format_ids(r.played)} in {r.seconds}s; {verb} {r.out}"
    return (
        f"nothing played: every sequence asked for was already in {r.out}, kept as it was "
        f"(the file's runs took {r['wall_seconds']}s)"
    )


def figures(r) -> str:
    """The headline figures of the sequences asked for, computed from their rows."""
    a = r.asked
    line = (
        f"cost per task {a['cost_per_task']}, actions per task {a['actions_per_task']}, "
        f"success rate {a['success_rate']}, improvement vs myopic {a['improvement_vs_myopic']}"
    )
    if a.get("improvement_note"):
        line += f" ({a['improvement_note']})"
    return line
