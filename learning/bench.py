"""Benchmark of the DQN trainer: environment steps/s, gradient updates/s, and what the boundary target costs.

For each horizon it builds the trainer of `learning.dqn` (Table A.2 settings and
the layout's demonstrations), then times

- acting: ε-greedy steps on the persistent world, storing each transition (ε = 0.5,
  half the steps run the network);
- updates: `Trainer.update` (minibatch with the protected demo share, Double-DQN
  targets, backward, clipped Adam step), in two regimes of the agent's memory:
  *early* (the acting steps above: few completions in a minibatch) and *competent*
  (the myopic oracle's demonstrations: the completion share of a policy that solves
  its tasks, where the anticipatory boundary target is largest);
- the boundary target alone: on the same minibatches, the anticipatory targets minus
  the myopic ones (which skip the boundary), with the per-sync cache of target values
  (`learning.qnet.BoundaryCache`, cleared every target_every updates as in training)
  and without it. Its share is of the time of one update.

    python -m learning.bench --layout two-room [--updates 1000] [--steps 2000] [--out FILE]

Absolute rates depend on what else runs on the machine; the shares are the point.
"""
from __future__ import annotations

import platform
import tempfile
import time

import numpy as np
import torch

from planning import cli
from planning.atomic import write_json
from planning.domain.compiler import compile_domain

from .dqn import HORIZONS, Config, Trainer, domain_defaults
from .qnet import COMPLETE, BoundaryCache, td_targets
from .replay import mixed_batch


def acting_rate(trainer: Trainer, steps: int, eps: float) -> float:
    """Environment steps per second of ε-greedy acting with storage (no updates)."""
    t = time.perf_counter()
    for _ in range(steps):
        trainer.env_step(eps)
    return steps / (time.perf_counter() - t)


def update_profile(trainer: Trainer, n: int) -> dict:
    """Updates/s and the boundary target's share of an update, with and without the cache."""
    cfg, enc = trainer.cfg, trainer.enc
    batches = [mixed_batch(trainer.memory, trainer.demos, cfg.batch_size, cfg.demo_fraction, trainer.rng)
               for _ in range(n)]

    def timed(horizon, cache):
        t = time.perf_counter()
        for i, b in enumerate(batches):
            if cache is not None and i % cfg.target_every == 0:
                cache.clear()
            td_targets(trainer.net, trainer.target, enc, b, cfg.gamma, horizon, cache)
        return (time.perf_counter() - t) / n

    t_myopic = timed("myopic", None)
    t_cached = timed("anticipatory", BoundaryCache())
    t_plain = timed("anticipatory", None)
    trainer.boundary.clear()
    t = time.perf_counter()
    for i in range(n):
        if i % cfg.target_every == 0:
            trainer.boundary.clear()
        trainer.update()
    t_update = (time.perf_counter() - t) / n
    completions = float(np.mean([(b["kinds"] == COMPLETE).sum() for b in batches]))
    out = {"updates_per_s": round(1 / t_update, 2), "update_ms": round(1000 * t_update, 2),
           "completions_per_minibatch": round(completions, 2)}
    if cfg.horizon == "anticipatory":
        b_cached, b_plain = max(0.0, t_cached - t_myopic), max(0.0, t_plain - t_myopic)   # timing noise
        out.update({"boundary_ms": round(1000 * b_cached, 2), "boundary_share": round(b_cached / t_update, 3),
                    "boundary_ms_uncached": round(1000 * b_plain, 2),
                    "boundary_share_uncached": round(b_plain / (t_update - b_cached + b_plain), 3),
                    "updates_per_s_uncached": round(1 / (t_update - b_cached + b_plain), 2)})
    return out


def bench_horizon(model_dir: str, layout: str, horizon: str, steps: int, updates: int, seed: int) -> dict:
    """Acting and update figures of one horizon's trainer."""
    model = compile_domain(model_dir, layout)
    with tempfile.TemporaryDirectory() as tmp:
        cfg = Config(**{**domain_defaults(model, horizon), "domain": model_dir, "layout": model.layout,
                        "horizon": horizon, "seed": seed, "steps": 0, "out": tmp})
        trainer = Trainer(cfg, progress=False)
        torch.manual_seed(seed)
        env = acting_rate(trainer, steps, eps=0.5)
        early = update_profile(trainer, updates)
        trainer.memory = trainer.demos          # a competent policy's completion share
        competent = update_profile(trainer, updates)
    loop = 1 / (1 / env + 1 / competent["updates_per_s"])
    return {"env_steps_per_s": round(env, 1), "early": early, "competent": competent,
            "train_steps_per_s_competent": round(loop, 1), "demo_transitions": len(trainer.demos)}


def main() -> None:
    p = cli.parser(__doc__.splitlines()[0], seed=True)
    p.add_argument("--steps", type=int, default=2000, help="acting steps timed (default 2000)")
    p.add_argument("--updates", type=int, default=1000,
                   help="updates timed per regime (default 1000: one target-sync period)")
    p.add_argument("--horizons", default=",".join(HORIZONS))
    args = p.parse_args()
    torch.set_num_threads(1)
    model = compile_domain(args.domain, args.layout)
    cli.check_writable(args.out or f"results/dqn-bench-{model.layout}.json")
    out = {"domain": model.name, "layout": model.layout, "steps": args.steps, "updates": args.updates,
           "threads": torch.get_num_threads(), "machine": f"{platform.machine()} {platform.python_implementation()} "
                                                           f"{platform.python_version()}"}
    for h in args.horizons.split(","):
        r = bench_horizon(args.domain, model.layout, h, args.steps, args.updates, args.seed)
        out[h] = r
        c, e = r["competent"], r["early"]
        line = (f"{h:12s} env {r['env_steps_per_s']:.0f} steps/s | updates/s early {e['updates_per_s']:.1f}, "
                f"competent {c['updates_per_s']:.1f} ({c['completions_per_minibatch']:.1f} completions/minibatch)")
        if "boundary_share" in c:
            line += (f" | boundary share early {e['boundary_share']:.0%}, competent {c['boundary_share']:.0%} "
                     f"(uncached {c['boundary_share_uncached']:.0%}, {c['updates_per_s_uncached']:.1f} updates/s)")
        print(line, flush=True)
    path = args.out or f"results/dqn-bench-{model.layout}.json"
    write_json(path, out)
    print(f"wrote {path}")


if __name__ == "__main__":
    cli.run(main)
