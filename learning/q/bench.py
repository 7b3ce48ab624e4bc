"""Benchmark of the DQN trainer: environment steps/s, gradient updates/s, and what the boundary target costs.

For each horizon it builds the trainer of `learning.dqn` (Table A.2 settings and
the layout's demonstrations), then times

- acting: ε-greedy steps on the persistent world, storing each transition (ε = 0.5,
  half the steps run the network; and ε = 0.05, the rate after the decay);
- updates: `Trainer.update` (minibatch with the protected demo share, Double-DQN
  targets, backward, clipped Adam step), in two regimes of the agent's memory:
  *early* (the acting steps above: few completions in a minibatch) and *competent*
  (the myopic oracle's demonstrations: the completion share of a policy that solves
  its tasks, where the anticipatory boundary target is largest);
- the boundary target alone: on the same minibatches, the anticipatory targets minus
  the myopic ones (which skip the boundary), with the per-sync cache of target values
  (`learning.q.targets.BoundaryCache`, cleared every target_every updates as in training)
  and without it. Its share is of the time of one update;
- the parts of an update (`parts_ms`): the targets, the forward and backward pass of the
  minibatch, the clipped Adam step;
- the matrix products (`matmul_*`, torch's profiler over the same updates once more): their share
  of the update's CPU time and their rate in GFLOPS, which says how far the update is from its
  arithmetic (a rate near the core's float32 peak and a share near 1 leave nothing to gain without
  doing less arithmetic).

A training step is one ε = 0.05 acting step and one update: `train_steps_per_s_*`.

With --seeds S (S > 1) it also times S seeds trained in one process (`learning.q.seeds.SeedBatch`)
against one seed alone, both on the demonstrations (the competent regime), in alternating rounds of
50 updates so that both see the same machine: `seeds.ratio` is the S seeds' aggregate updates/s over
the single seed's.

With --device cuda it also times one seed's updates with its networks on the GPU against the same trainer
on the CPU (`device_profile`: wall clock, alternating rounds, the device synchronised after each round).

    python -m learning.q.bench --layout two-room [--updates 1000] [--steps 2000] [--seeds 4] [--device cuda]
        [--out FILE]

Times are this process's CPU time (torch runs one thread): on a free core that is the
wall time, on a shared machine it is what the work costs rather than how long it waited
for a core. Absolute rates still depend on what else runs (caches, memory bandwidth);
ratios measured in one process are the dependable figures.
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
from planning.parallel import results_provenance

from .replay import COMPLETE, mixed_batch
from .targets import BoundaryCache, td_targets
from .training import HORIZONS, Config, Trainer, domain_defaults

clock = time.process_time
MATMUL_OPS = ("aten::addmm", "aten::mm", "aten::bmm", "aten::addmv", "aten::mv", "aten::dot")


def acting_rate(trainer: Trainer, steps: int, eps: float) -> float:
    """Environment steps per second of ε-greedy acting with storage (no updates)."""
    t = clock()
    for _ in range(steps):
        trainer.env_step(eps)
    return steps / (clock() - t)


def update_profile(trainer: Trainer, n: int) -> dict:
    """Updates/s and the boundary target's share of an update, with and without the cache."""
    cfg, enc = trainer.cfg, trainer.enc
    batches = [
        mixed_batch(trainer.memory, trainer.demos, cfg.batch_size, cfg.demo_fraction, trainer.rng) for _ in range(n)
    ]

    def timed(horizon, cache):
        t = clock()
        for i, b in enumerate(batches):
            if cache is not None and i % cfg.target_every == 0:
                cache.clear()
            td_targets(trainer.net, trainer.target, enc, b, cfg.gamma, horizon, cache)
        return (clock() - t) / n

    t_myopic = timed("myopic", None)
    t_cached = timed("anticipatory", BoundaryCache())
    t_plain = timed("anticipatory", None)
    trainer.boundary.clear()
    t = clock()
    for i in range(n):
        if i % cfg.target_every == 0:
            trainer.boundary.clear()
        trainer.update()
    t_update = (clock() - t) / n
    # the same updates in their parts: targets (line 11-19), forward + backward, clip + Adam
    parts = {"targets": 0.0}
    trainer.boundary.clear()
    for i, b in enumerate(batches):
        if i % cfg.target_every == 0:
            trainer.boundary.clear()
        t = clock()
        y = trainer.targets(b)
        parts["targets"] += clock() - t
        trainer.descend(b, y, parts)
    completions = float(np.mean([(b["kinds"] == COMPLETE).sum() for b in batches]))
    out = {
        "updates_per_s": round(1 / t_update, 2),
        "update_ms": round(1000 * t_update, 2),
        "completions_per_minibatch": round(completions, 2),
        "parts_ms": {k: round(1000 * v / n, 2) for k, v in parts.items()},
        **matmul_profile(trainer, batches),
    }
    if cfg.horizon == "anticipatory":
        b_cached, b_plain = max(0.0, t_cached - t_myopic), max(0.0, t_plain - t_myopic)  # timing noise
        out.update(
            {
                "boundary_ms": round(1000 * b_cached, 2),
                "boundary_share": round(b_cached / t_update, 3),
                "boundary_ms_uncached": round(1000 * b_plain, 2),
                "boundary_share_uncached": round(b_plain / (t_update - b_cached + b_plain), 3),
                "updates_per_s_uncached": round(1 / (t_update - b_cached + b_plain), 2),
            }
        )
    return out


def matmul_profile(trainer: Trainer, batches: list, chunk: int = 50) -> dict:
    """The matrix products' CPU time per update, their share of the update's (both as torch's profiler
    counts them, self time per operation) and their rate, over the given minibatches.

    The profiler keeps every operation's record with its shapes, about 9 MB an update here, so the
    updates are profiled `chunk` at a time and only the sums are kept (1,000 updates at once held
    about 9 GB)."""
    from torch.profiler import ProfilerActivity, profile

    total = t = flops = 0.0  # microseconds, FLOPs
    for lo in range(0, len(batches), chunk):
        with profile(activities=[ProfilerActivity.CPU], with_flops=True) as prof:
            for i in range(lo, min(lo + chunk, len(batches))):
                if i % trainer.cfg.target_every == 0:
                    trainer.boundary.clear()
                trainer.update(batches[i])
        ops = prof.key_averages()
        total += sum(e.self_cpu_time_total for e in ops)
        mm = [e for e in ops if e.key in MATMUL_OPS]
        t += sum(e.self_cpu_time_total for e in mm)
        flops += sum(e.flops for e in mm)
        del prof, ops, mm
    return {
        "matmul_ms": round(t / 1000 / len(batches), 2),
        "matmul_share": round(t / total, 3) if total else 0.0,
        "matmul_gflops": round(flops / t / 1e3, 1) if t else 0.0,
    }


def bench_config(model_dir: str, model, horizon: str, seed: int, out: str) -> Config:
    """The trainer settings a benchmark times: the layout's (Table A.2, then domain.toml), no steps of its own."""
    return Config(
        **{
            **domain_defaults(model, horizon),
            "domain": model_dir,
            "layout": model.layout,
            "horizon": horizon,
            "seed": seed,
            "steps": 0,
            "out": out,
        }
    )


def seeds_profile(model_dir: str, layout: str, horizon: str, n_seeds: int, updates: int, seed: int) -> dict:
    """Aggregate updates/s of n_seeds seeds in one `SeedBatch` against one seed alone (module docstring)."""
    from .seeds import SeedBatch

    model = compile_domain(model_dir, layout)
    with tempfile.TemporaryDirectory() as tmp:
        cfg = lambda s: bench_config(model_dir, model, horizon, s, f"{tmp}/{s}")
        single = Trainer(cfg(seed), progress=False)
        trainers = [Trainer(cfg(seed + k), progress=False) for k in range(n_seeds)]
        batch = SeedBatch(trainers)
        for t in (single, *trainers):
            t.memory = t.demos  # a competent policy's completion share
        chunk, rounds = 50, max(1, updates // 50)
        t_single = t_batch = 0.0
        for r in range(rounds):
            if r * chunk % single.cfg.target_every == 0:
                for t in (single, *trainers):
                    t.sync_target()
            t = clock()
            for _ in range(chunk):
                single.update()
            t_single += clock() - t
            t = clock()
            for _ in range(chunk):
                batch.update()
            t_batch += clock() - t
    n = rounds * chunk
    return {
        "seeds": n_seeds,
        "updates": n,
        "single_updates_per_s": round(n / t_single, 2),
        "aggregate_updates_per_s": round(n_seeds * n / t_batch, 2),
        "per_seed_updates_per_s": round(n / t_batch, 2),
        "ratio": round(n_seeds * t_single / t_batch, 3),
    }


def device_profile(model_dir: str, layout: str, horizon: str, updates: int, seed: int, device: str) -> dict:
    """Updates/s of one seed's trainer with its networks on `device` against the same trainer on the CPU, both
    on the demonstrations (the competent regime), in alternating rounds of 50 updates; wall-clock time, the
    device synchronised at the end of each round (its kernels run asynchronously)."""
    from learning.device import check_device

    dev = check_device(device)
    sync = torch.cuda.synchronize if dev.type == "cuda" else (lambda: None)
    model = compile_domain(model_dir, layout)
    with tempfile.TemporaryDirectory() as tmp:
        cfg = lambda where: bench_config(model_dir, model, horizon, seed, f"{tmp}/{where}")
        runs = {"cpu": Trainer(cfg("cpu"), progress=False), "device": Trainer(cfg("device"), False, dev)}
        for t in runs.values():
            t.memory = t.demos
        spent = dict.fromkeys(runs, 0.0)
        done = 0
        while done < updates:
            n = min(50, updates - done)
            for key, t in runs.items():
                start = time.perf_counter()
                for _ in range(n):
                    t.update()
                sync()
                spent[key] += time.perf_counter() - start
            done += n
    return {
        "device": str(dev),
        "updates": updates,
        "cpu_updates_per_s": round(updates / spent["cpu"], 2),
        "device_updates_per_s": round(updates / spent["device"], 2),
        "ratio": round(spent["cpu"] / spent["device"], 3),
    }


def bench_horizon(model_dir: str, layout: str, horizon: str, steps: int, updates: int, seed: int) -> dict:
    """Acting and update figures of one horizon's trainer."""
    model = compile_domain(model_dir, layout)
    with tempfile.TemporaryDirectory() as tmp:
        cfg = bench_config(model_dir, model, horizon, seed, tmp)
        trainer = Trainer(cfg, progress=False)
        torch.manual_seed(seed)
        env = acting_rate(trainer, steps, eps=0.5)
        greedy = acting_rate(trainer, steps, eps=0.05)
        early = update_profile(trainer, updates)
        trainer.memory = trainer.demos  # a competent policy's completion share
        competent = update_profile(trainer, updates)
    loop = lambda r: round(1 / (1 / greedy + 1 / r["updates_per_s"]), 1)
    return {
        "env_steps_per_s": round(env, 1),
        "env_steps_per_s_greedy": round(greedy, 1),
        "early": early,
        "competent": competent,
        "train_steps_per_s_early": loop(early),
        "train_steps_per_s_competent": loop(competent),
        "demo_transitions": len(trainer.demos),
    }


def main() -> None:
    p = cli.parser(__doc__.splitlines()[0], seed=True)
    p.add_argument("--steps", type=int, default=2000, help="acting steps timed (default 2000)")
    p.add_argument(
        "--updates", type=int, default=1000, help="updates timed per regime (default 1000: one target-sync period)"
    )
    p.add_argument("--horizons", default=",".join(HORIZONS))
    p.add_argument(
        "--seeds",
        type=int,
        default=1,
        help="also time this many seeds trained in one process against one (default 1: not)",
    )
    p.add_argument("--skip-single", action="store_true", help="time only the seeds trained together (with --seeds)")
    p.add_argument(
        "--device",
        default=None,
        help="also time one seed's updates with its networks on this device (cuda) against the CPU (wall clock)",
    )
    args = p.parse_args()
    torch.set_num_threads(1)
    model = compile_domain(args.domain, args.layout)
    cli.check_writable(args.out or f"results/dqn-bench-{model.layout}.json")
    out = {
        "domain": model.name,
        "layout": model.layout,
        "steps": args.steps,
        "updates": args.updates,
        "threads": torch.get_num_threads(),
        "machine": f"{platform.machine()} {platform.python_implementation()} {platform.python_version()}",
    }
    for h in args.horizons.split(","):
        if args.seeds > 1:
            r = seeds_profile(args.domain, model.layout, h, args.seeds, args.updates, args.seed)
            out.setdefault("seeds", {})[h] = r
            print(
                f"{h:12s} {r['seeds']} seeds in one process: {r['aggregate_updates_per_s']:.1f} updates/s in all, one "
                f"seed alone {r['single_updates_per_s']:.1f}: {r['ratio']:.2f}x (competent regime, {r['updates']} "
                "updates each)",
                flush=True,
            )
        if args.device is not None:
            r = device_profile(args.domain, model.layout, h, args.updates, args.seed, args.device)
            out.setdefault("device", {})[h] = r
            print(
                f"{h:12s} on {r['device']}: {r['device_updates_per_s']:.1f} updates/s against "
                f"{r['cpu_updates_per_s']:.1f} on the CPU: {r['ratio']:.2f}x (competent regime, wall clock)",
                flush=True,
            )
        if args.skip_single:
            continue
        r = bench_horizon(args.domain, model.layout, h, args.steps, args.updates, args.seed)
        out[h] = r
        c, e = r["competent"], r["early"]
        line = (
            f"{h:12s} env {r['env_steps_per_s_greedy']:.0f} steps/s | updates/s early {e['updates_per_s']:.1f}, "
            f"competent {c['updates_per_s']:.1f} ({c['update_ms']:.1f} ms; "
            f"{c['completions_per_minibatch']:.1f} completions/minibatch) | train steps/s early "
            f"{r['train_steps_per_s_early']:.1f}, competent {r['train_steps_per_s_competent']:.1f} | matrix products "
            f"{c['matmul_share']:.0%} of a competent update at {c['matmul_gflops']:.0f} GFLOPS"
        )
        if "boundary_share" in c:
            line += (
                f" | boundary share early {e['boundary_share']:.0%}, competent {c['boundary_share']:.0%} "
                f"(uncached {c['boundary_share_uncached']:.0%}, {c['updates_per_s_uncached']:.1f} updates/s)"
            )
        print(line, flush=True)
    path = args.out or f"results/dqn-bench-{model.layout}.json"
    write_json(path, {**out, "provenance": results_provenance(out)})
    print(f"wrote {path}")


if __name__ == "__main__":
    cli.run(main)
