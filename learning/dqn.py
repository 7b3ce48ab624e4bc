"""Online value learning: the anticipatory / myopic factored Double-DQN of the thesis (Algorithm 1, §4.1).

The command that trains one run, or several seeds in one process (the trainer: `learning.q.training`):

    python -m learning.dqn --layout two-room --horizon anticipatory --seed 0 [--steps N] [--out DIR]
    python -m learning.dqn --layout two-room --horizon anticipatory --seed 0,4,8,16

Every field of `learning.q.training.Config` is a flag (defaults: Table A.2, then domain.toml
[training]). Writes DIR/metrics.jsonl, DIR/last.pt (rerun the same command to resume) and
DIR/best.pt; prints the run's last figures. Several seeds are independent runs (each its own
world, stream, memories, exploration and target network, each in its own folder: DIR/seed<N>
with --out) whose updates are batched together (`learning.q.seeds`): the same algorithm as
training each alone, at a fraction of the cost per update. `--device cuda` trains one run's
networks on a GPU (`learning.device`).
"""

from __future__ import annotations

from dataclasses import fields

from learning.q.training import HORIZONS, Config, last_row, make_config, train_runs
from planning import cli
from planning.errors import DomainError


def seed_list(text: str) -> list[int]:
    """--seed: one seed or several, comma-separated."""
    try:
        seeds = [int(part) for part in text.split(",")]
    except ValueError:
        raise DomainError("--seed", f"'{text}' is not a seed or a comma-separated list of seeds") from None
    if len(set(seeds)) != len(seeds):
        raise DomainError("--seed", f"a seed is listed twice in '{text}'")
    return seeds


def main() -> None:
    p = cli.parser(__doc__.splitlines()[0], domain=False, layout=False, out=None, progress=True)
    cli.add_dataclass_options(p, Config, skip=("horizon", "seed"))  # --domain, --layout, --out: Config's
    p.add_argument("--horizon", required=True, choices=HORIZONS, help=cli.field_docs(Config)["horizon"])
    p.add_argument(
        "--seed",
        default="0",
        help="seed of the run, or several comma-separated seeds trained together in one process (default 0)",
    )
    p.add_argument(
        "--device",
        default=None,
        help="where the networks train: cpu (the default) or cuda[:N] (learning.device; one seed at a time)",
    )
    p.add_argument(
        "--fresh",
        action="store_true",
        help="ignore an existing last.pt and start over (the run's metrics.jsonl, best.pt and last.pt are replaced)",
    )
    args = p.parse_args()
    seeds = seed_list(args.seed)
    given = {f.name: getattr(args, f.name) for f in fields(Config) if f.name != "seed"}
    cfgs = []
    for seed in seeds:
        out = given["out"] if len(seeds) == 1 or given["out"] is None else f"{given['out']}/seed{seed}"
        cfgs.append(make_config(**{**given, "seed": seed, "out": out}))
    for trainer in train_runs(cfgs, fresh=args.fresh, progress=not args.no_progress, device=args.device):
        cfg, row, best = trainer.cfg, last_row(trainer.metrics), trainer.best or {}
        print(
            f"{cfg.horizon} {cfg.layout} seed {cfg.seed}: step {trainer.step}, success (last 100) "
            f"{row.get('success_rate', float('nan')):.3f}, task return {row.get('task_return', float('nan')):.2f}, "
            f"best greedy eval {best.get('eval')} at step {best.get('step')}; wrote {trainer.out}"
        )


if __name__ == "__main__":
    cli.run(main)
