"""A finished training run, made small enough to commit: its compact checkpoint and its key figures.

    python -m learning.export runs/dqn/restaurant-three-room-anticipatory-seed0   # a learning.dqn run
    python -m learning.export runs/gnn/three-room-faithful-seed0                  # a learning.gnn_train run
    python -m learning.export runs/gnn/three-room-augmented                       # a learning.gnn_dataset folder
        [--out CHECKPOINT] [--figures JSON]

- The compact checkpoint is the run's best.pt (the network the run selected: the
  best greedy evaluation, the lowest validation L1) with its weights in float16:
  half the bytes, loaded safely (weights_only) by every agent and cast back to
  float32 there. A Q-network stays in float32 if float16 would change its greedy
  action on one of 1,000 probe (state, task) pairs to one its float32 values lower
  by a tie (0.01) or more: a diverged network's values are so large that float16's
  rounding moves them by more than their action gaps. It keeps the run's step or epoch, evaluation, settings and the
  sha256 of the best.pt it came from. Default: checkpoints/rl-<horizon>-<layout>-seed<N>.pt,
  checkpoints/gnn-<faithful|augmented>-<layout>-seed<N>.pt.
- The key figures of a Q-learning run are what Appendix A.2 reports of it, read
  from its metrics.jsonl: at 50k, 100k, 250k and 500k steps (or the nearest logged
  step before), the success rate over the last 100 training tasks, the selected Q,
  the TD target and the share of refill-water actions in the last log window; the
  greedy evaluations (and, for a myopic run, demo_q_bias: Q above the myopic
  oracle's return on the demonstrations, the divergence alarm); the largest selected
  Q of the run and where, and the largest refill-water share, per log window and cumulative
  since step 0 (the authors' code plots the cumulative share: the thesis's Figure A.2);
  the wall time of the training loop (the sum of each
  log window's steps over its measured rate); and the run's curve, a row every
  5,000 steps with Figure A.1's four series and the cumulative refill-water share,
  so that the report redraws Figure A.1 from committed files (about 10 KB a run). A GNN run's are its summary.json
  (validation L1, best epoch, seconds per epoch). Default: results/training-<name>.json.
- A GNN dataset (megabytes of graphs) is committed as its key figures only, read from its
  meta.json: the settings it was built with, its states per kind (faithful, prepared), the
  exact C_AP labels' spread, and what labelling them cost. Default:
  results/dataset-gnn-<faithful|augmented>-<layout>.json; there is no checkpoint.
"""
from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path

import numpy as np


from planning import cli
from planning.atomic import sha256, write_json
from planning.errors import DomainError
from planning.world.runner import results_provenance

from planning.domain.compiler import compile_domain

from learning.plain import full_precision, to_half
from learning.dqn import LEGACY, Config, bound_suffix, read_metrics
from learning.qnet import read_checkpoint, save_checkpoint, value_function

MILESTONES = (50_000, 100_000, 250_000, 500_000)
PRECISION = "float16"
PROBE_STATES = 1000           # (state, task) pairs on which a float16 checkpoint must act as its float32 source
TIE = 0.01                    # Q gaps below this are ties (trained values are tens to hundreds)
CURVE_EVERY = 5_000           # steps between the rows of a run's exported curve
CURVE_KEYS = ("success_rate", "task_return", "selected_q", "td_target")      # Figure A.1's panels


def compact(payload: dict, source: str | None = None, half: bool = True) -> dict:
    """The agent-facing part of a Q-network checkpoint, float tensors in float16 (`read_checkpoint` casts them
    back); `half=False` keeps them in float32."""
    keep = {k: payload[k] for k in ("dims", "signature", "step", "eval", "config") if k in payload}
    net, precision = (to_half(payload["net"]), PRECISION) if half else (payload["net"], "float32")
    return {**keep, "net": net, "precision": precision, **({"source_sha256": source} if source else {})}


def compact_gnn(payload: dict, source: str | None = None) -> dict:
    """A GNN checkpoint with its weights in float16 (`read_gnn_checkpoint` casts them back)."""
    return {**payload, "model": to_half(payload["model"]), "precision": PRECISION,
            **({"source_sha256": source} if source else {})}


def greedy_loss(payload: dict, small: dict, model, n: int = PROBE_STATES) -> float:
    """The most value the compact checkpoint's greedy action gives up, as the full network values it, over
    `n` probe (state, task) pairs along seeded random walks of `model` (0 where it acts as the full one)."""
    states = model.random_walk_states(n, seed=0)
    tasks = np.random.default_rng(0).integers(len(model.tasks), size=n)
    full, half = value_function(payload, model), value_function(full_precision(dict(small), "net"), model)
    packed = full.enc.pack(states)
    obs, valid = full.enc.observe(packed, tasks), full.enc.valid_for(packed, tasks)
    q = full.fast(obs, valid)
    rows = np.arange(n)
    return float(np.max(q[rows, q.argmax(1)] - q[rows, half.fast(obs, valid).argmax(1)]))


def faithful_compact(payload: dict, source: str | None = None) -> tuple[dict, float]:
    """(compact checkpoint, float16's greedy loss): float16 weights where they change no greedy action by more
    than a tie (TIE), float32 otherwise (a network whose values are so large that float16's rounding moves
    them by more than their action gaps, as a diverged run's)."""
    cfg = payload.get("config", {})
    layout = cfg.get("layout") or payload.get("signature", {}).get("layout")
    if not layout:
        raise DomainError("checkpoint", "names no layout (config or signature) to probe its float16 copy on")
    small = compact(payload, source)
    loss = greedy_loss(payload, small, compile_domain(cfg.get("domain", Config.domain), layout))
    return (small if loss < TIE else compact(payload, source, half=False)), loss


def split_metrics(path: Path) -> tuple[list[dict], list[dict]]:
    """(log rows, evaluation rows) of a run's metrics.jsonl."""
    rows, _ = read_metrics(path)
    return [r for r in rows if "eval" not in r], [r["eval"] for r in rows if "eval" in r]


def key_figures(logs: list[dict], evals: list[dict], refill: str = "refill-water") -> dict:
    """What Appendix A.2 reports of a run (see the module's docstring)."""
    if not logs:
        return {"steps": 0}
    last = logs[-1]["step"]
    cumulative, done, prev = {}, 0.0, 0          # refill-water actions since step 0, over the steps
    for r in logs:
        done += (r.get("action_share", {}).get(refill) or 0.0) * (r["step"] - prev)
        prev = r["step"]
        cumulative[r["step"]] = round(done / r["step"], 5) if r["step"] else 0.0
    at = {}
    for m in MILESTONES:
        if m > last:
            continue
        row = max((r for r in logs if r["step"] <= m), key=lambda r: r["step"])
        ev = [e for e in evals if e["step"] <= m]
        at[str(m)] = {"step": row["step"], "success_last_100": row["success_rate"],
                      "selected_q": round(row["selected_q"], 3), "td_target": round(row["td_target"], 3),
                      "refill_share": row.get("action_share", {}).get(refill),
                      "refill_share_cumulative": cumulative[row["step"]],
                      **({"greedy": _eval(ev[-1])} if ev else {})}
    peak = max(logs, key=lambda r: abs(r["selected_q"]) if r["selected_q"] == r["selected_q"] else 0.0)
    best = max(evals, key=lambda e: (e["success_rate"], e["task_return"])) if evals else None
    seconds, prev = 0.0, 0
    for r in logs:                       # each row's rate is measured over the steps since the row before
        if r.get("steps_per_s"):
            seconds += (r["step"] - prev) / r["steps_per_s"]
        prev = r["step"]
    refills = [(r.get("action_share", {}).get(refill) or 0.0, r["step"]) for r in logs]
    top = max(refills)
    top_cumulative = max((share, step) for step, share in cumulative.items())
    return {"steps": last, "at": at, "best_greedy": _eval(best) if best else None,
            "peak_selected_q": {"step": peak["step"], "selected_q": round(peak["selected_q"], 3)},
            "peak_refill_share": {"step": top[1], "share": top[0]},
            "peak_refill_share_cumulative": {"step": top_cumulative[1], "share": top_cumulative[0]},
            "train_hours": round(seconds / 3600, 3),
            "steps_per_s_median": _median([r["steps_per_s"] for r in logs if r.get("steps_per_s")]),
            "curve": [{"step": r["step"], **{k: _short(r[k]) for k in CURVE_KEYS if k in r},
                       "refill_share_cumulative": cumulative[r["step"]]}
                      for r in logs if r["step"] % CURVE_EVERY == 0 or r is logs[-1]]}


def _short(x):
    """Five significant digits: a curve to draw, not to resume from."""
    return float(f"{x:.5g}") if isinstance(x, float) else x


def _eval(e: dict) -> dict:
    keys = ("step", "success_rate", "cost_per_task", "task_return", "demo_q_bias")
    return {k: (round(e[k], 4) if isinstance(e[k], float) else e[k]) for k in keys if k in e}


def _median(xs: list) -> float | None:
    xs = sorted(xs)
    return round(xs[len(xs) // 2], 2) if xs else None


def is_dataset(folder: Path) -> bool:
    """True for a learning.gnn_dataset folder (meta.json and graphs, no checkpoint)."""
    return (folder / "meta.json").is_file() and not (folder / "best.pt").exists()


def dataset_figures(folder: Path) -> dict:
    """A GNN dataset's key figures from its meta.json (see the module's docstring)."""
    try:
        meta = json.loads((folder / "meta.json").read_text())
        kinds, c_ap, secs = meta["kinds"], np.asarray(meta["c_ap"], float), np.asarray(meta["label_seconds"], float)
    except (OSError, json.JSONDecodeError, KeyError, TypeError, ValueError) as e:
        raise DomainError(folder / "meta.json", f"not a GNN dataset's metadata ({type(e).__name__}: {e})") from None
    if not len(kinds) == len(c_ap) == len(secs) == meta.get("n", len(kinds)) or not len(kinds):
        raise DomainError(folder / "meta.json", "its kinds, labels and label times do not count the same states")
    spread = lambda x, d: {k: round(float(f(x)), d) for k, f in
                           (("mean", np.mean), ("min", np.min), ("median", np.median), ("max", np.max))}
    cfg = meta.get("config", {})
    return {"dataset": str(folder), "domain": meta.get("domain"), "layout": meta.get("layout"),
            "variant": "augmented" if cfg.get("augmented", "prepared" in kinds) else "faithful",
            "states": len(kinds), "kinds": dict(Counter(kinds)), "tasks": len(meta.get("tasks", [])),
            "features": len(meta.get("feature_names", [])), "config": cfg, "c_ap": spread(c_ap, 2),
            "label_seconds": spread(secs, 4),
            **{k: meta[k] for k in ("seconds_faithful_states", "seconds_collecting_and_labelling",
                                    "label_cpu_seconds") if k in meta}}


def is_gnn_run(run: Path) -> bool:
    """True for a learning.gnn_train run folder, False for a learning.dqn one (by its best.pt)."""
    from learning.gnn_model import is_gnn_checkpoint

    return is_gnn_checkpoint(run / "best.pt")


def default_names(run: Path, gnn: bool) -> tuple[str, str]:
    """(checkpoint, figures) default paths of a run folder (`gnn`: a learning.gnn_train run)."""
    if gnn:
        from learning.gnn_model import read_gnn_checkpoint

        p = read_gnn_checkpoint(run / "best.pt")
        cfg = p.get("config", {})
        try:
            augmented = json.loads((Path(cfg.get("data", "")) / "meta.json").read_text())["config"]["augmented"]
        except (OSError, KeyError, TypeError, json.JSONDecodeError):
            raise DomainError(run, f"cannot tell the dataset variant from {cfg.get('data')}/meta.json; "
                                   "pass --out and --figures") from None
        name = f"gnn-{'augmented' if augmented else 'faithful'}-{p.get('layout')}-seed{cfg.get('seed')}"
        return f"checkpoints/{name}.pt", f"results/training-{name}.json"
    name = rl_name(read_checkpoint(run / "best.pt").get("config", {}))
    return f"checkpoints/rl-{name}.pt", f"results/training-{name}.json"


def rl_name(cfg: dict, varied: str = "") -> str:
    """<horizon>-<layout>-seed<N>[varied][-bound-<bound>]: the name a Q-learning run's exported files share
    (checkpoints/rl-NAME.pt, results/training-NAME.json, results/rl-greedy-NAME.json); `varied` names a
    sweep's other settings."""
    return f"{cfg.get('horizon')}-{cfg.get('layout')}-seed{cfg.get('seed')}{varied}{bound_suffix(cfg)}"


def export_gnn(run: Path, out: Path, figures: Path | None) -> tuple[dict, dict]:
    """The compact GNN checkpoint and the run's summary.json (with where it came from)."""
    from learning.gnn_model import read_gnn_checkpoint, save_gnn_checkpoint

    best = run / "best.pt"
    small = compact_gnn(read_gnn_checkpoint(best), sha256(best))
    save_gnn_checkpoint(out, small)
    try:
        summary = json.loads((run / "summary.json").read_text())
    except (OSError, json.JSONDecodeError) as e:
        raise DomainError(run / "summary.json", f"cannot read the run's summary ({type(e).__name__})") from None
    figs = {"run": str(run), "checkpoint": str(out), "checkpoint_epoch": small.get("epoch"), **summary}
    if figures is not None:
        write_json(figures, {**figs, "provenance": results_provenance(figs)})
    return small, figs


def export(run: Path, out: Path, figures: Path | None) -> tuple[dict, dict]:
    """Write the compact checkpoint (and the key figures); returns (compact payload, figures)."""
    best = run / "best.pt"
    payload = read_checkpoint(best)
    small, loss = faithful_compact(payload, sha256(best))
    save_checkpoint(out, small)
    logs, evals = split_metrics(run / "metrics.jsonl")
    cfg = payload.get("config", {})
    figs = {"run": str(run), "checkpoint": str(out), "checkpoint_step": payload.get("step"),
            "checkpoint_precision": small["precision"], "float16_greedy_loss": loss,
            **{k: cfg.get(k) for k in ("domain", "layout", "horizon", "seed", "steps", "gamma")},
            **{k: cfg.get(k, was) for k, was in LEGACY.items()},
            **key_figures(logs, evals)}
    if figures is not None:
        write_json(figures, {**figs, "provenance": results_provenance(figs)})
    return small, figs


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("run", help="a learning.dqn run folder (best.pt, metrics.jsonl), a learning.gnn_train one "
                               "(best.pt, summary.json) or a learning.gnn_dataset folder (meta.json)")
    p.add_argument("--out", help="compact checkpoint (default: checkpoints/rl-<horizon>-<layout>-seed<N>.pt, "
                                 "checkpoints/gnn-<variant>-<layout>-seed<N>.pt)")
    p.add_argument("--figures", help="key figures JSON (default: results/training-<checkpoint name without rl->.json)")

    def run():
        args = p.parse_args()
        folder = Path(args.run)
        if is_dataset(folder):
            if args.out:
                raise DomainError("--out", "a dataset has no checkpoint; --figures names its key figures")
            figs = dataset_figures(folder)
            figures = Path(args.figures or f"results/dataset-gnn-{figs['variant']}-{figs['layout']}.json")
            cli.check_writable(figures)
            write_json(figures, {**figs, "provenance": results_provenance(figs)})
            print(f"wrote {figures}: {figs['states']:,} states ("
                  + ", ".join(f"{v:,} {k}" for k, v in figs["kinds"].items())
                  + f"), mean C_AP {figs['c_ap']['mean']:,.1f}")
            return
        gnn = is_gnn_run(folder)
        names = default_names(folder, gnn) if not (args.out and args.figures) else (args.out, args.figures)
        out, figures = Path(args.out or names[0]), Path(args.figures or names[1])
        cli.check_writable(out)
        cli.check_writable(figures)
        if gnn:
            small, figs = export_gnn(folder, out, figures)
            print(f"wrote {out} ({out.stat().st_size / 1e3:.0f} KB, {PRECISION}, epoch {small.get('epoch')}, "
                  f"validation L1 {figs['best_val_l1']:.2f}) and {figures}")
            return
        small, figs = export(folder, out, figures)
        at = figs.get("at", {})
        kept = "" if small["precision"] == PRECISION else (f": float16 would give up {figs['float16_greedy_loss']:,.4g}"
                                                        f" of value on a probe state's greedy action")
        print(f"wrote {out} ({out.stat().st_size / 1e3:.0f} KB, {small['precision']}{kept}, step {small.get('step')}) "
              f"and {figures}: {figs['steps']:,} steps in {figs['train_hours']} h; success (last 100) "
              + ", ".join(f"{int(k) // 1000}k {v['success_last_100']:.2f}" for k, v in at.items()))

    cli.run(run)


if __name__ == "__main__":
    main()
