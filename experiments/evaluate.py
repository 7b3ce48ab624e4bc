"""Play a registered agent on the canonical sequences under the persistent-world rules; write the results JSON.

    python -m experiments.evaluate --list-agents
    python -m experiments.evaluate --agent myopic-oracle --layout two-room [--planner internal] [--sequences 0-9]
    python -m experiments.evaluate --agent rl-greedy --checkpoint checkpoints/rl-anticipatory-two-room-seed0.pt --layout two-room
    python -m experiments.evaluate --agent myopic-oracle --layout two-room --workers 2      # or --ray

Each agent declares its own options (`--agent NAME --help` lists them). The
default results file is results/<agent's run name>-<layout>.json; an
interrupted run resumes from OUT.partial.json, a finished one is extended by
more sequences, and a finished file made with another configuration is never
replaced unless --force is given. The runner is `planning.world.runner`.
--workers N plays the sequences on N local processes, --ray as Ray tasks
(`experiments.workers`); the results file is the serial run's.
"""

from __future__ import annotations

import sys

from oracles.command import RunOptions, figures, play, run_options, what_ran
from planning import cli
from planning.domain.compiler import compile_domain
from planning.parallel import one_thread

from .registry import AGENTS, agent_class, agent_options, build, describe
from .workers import Job, play_over_workers


def main() -> None:
    known = cli.peek(agent=None, list_agents=False)
    if known.list_agents:
        print(describe())
        return
    p = cli.parser(
        __doc__.splitlines()[0],
        sequences=True,
        progress=True,
        workers=True,
        helps={
            "workers": "local processes, one sequence each at a time (default: 1, serial)",
            "ray": "sequences as Ray tasks: a local instance, or the cluster at RAY_ADDRESS",
        },
    )
    p.add_argument("--agent", required=True, help=f"one of: {', '.join(AGENTS)} (--list-agents describes them)")
    p.add_argument("--list-agents", action="store_true", help="print the registered agents and exit")
    run_options(p)
    cls = agent_class(known.agent) if known.agent else None
    if cls is not None:
        cls.options(p.add_argument_group(f"{known.agent} options"))
    args = p.parse_args()
    one_thread()  # torch and BLAS on one thread, as in the workers: serial and parallel runs compute alike
    ids = cli.parse_ids(args.sequences)
    model = compile_domain(args.domain, args.layout)
    options, run = agent_options(cls, args), RunOptions.from_args(args)
    agent = build(cls, options, model)

    def over_workers(out, log):  # each sequence a work item; the run below merges their rows
        if args.workers > 1 or args.ray:
            job = Job(known.agent, options, args.domain, model, agent, ids, out, run.force, run.failure_protocol, log)
            return play_over_workers([job], args.workers, args.ray, progress=run.progress)
        return None

    r, out = play(model, agent, ids, run, before=over_workers)
    print(f"{r['agent']} {r['layout']}, sequences {cli.format_ids(ids)}: {figures(r)}", file=sys.stdout)
    print(what_ran(r), file=sys.stdout)


if __name__ == "__main__":
    cli.run(main)
