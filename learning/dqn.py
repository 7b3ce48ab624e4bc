"""Online value learning: the anticipatory / myopic factored Double-DQN of the thesis (Algorithm 1, §4.1).

The command that trains one run (the trainer: `learning.q.training`):

    python -m learning.dqn --layout two-room --horizon anticipatory --seed 0 [--steps N] [--out DIR]

Every field of `learning.q.training.Config` is a flag (defaults: Table A.2, then domain.toml
[training]). Writes DIR/metrics.jsonl, DIR/last.pt (rerun the same command to resume) and
DIR/best.pt; prints the run's last figures.
"""

from __future__ import annotations

from dataclasses import fields

from learning.q.training import HORIZONS, Config, last_row, make_config, train_run
from planning import cli


def main() -> None:
    p = cli.parser(__doc__.splitlines()[0], domain=False, layout=False, out=None, progress=True)
    cli.add_dataclass_options(p, Config, skip=("horizon",))  # --domain, --layout, --seed, --out: Config's
    p.add_argument("--horizon", required=True, choices=HORIZONS, help=cli.field_docs(Config)["horizon"])
    p.add_argument(
        "--fresh",
        action="store_true",
        help="ignore an existing last.pt and start over (the run's metrics.jsonl, best.pt and last.pt are replaced)",
    )
    args = p.parse_args()
    cfg = make_config(**{f.name: getattr(args, f.name) for f in fields(Config)})
    trainer = train_run(cfg, fresh=args.fresh, progress=not args.no_progress)
    row = last_row(trainer.metrics)
    best = trainer.best or {}
    print(
        f"{cfg.horizon} {cfg.layout} seed {cfg.seed}: step {trainer.step}, success (last 100) "
        f"{row.get('success_rate', float('nan')):.3f}, task return {row.get('task_return', float('nan')):.2f}, "
        f"best greedy eval {best.get('eval')} at step {best.get('step')}; wrote {trainer.out}"
    )


if __name__ == "__main__":
    cli.run(main)
