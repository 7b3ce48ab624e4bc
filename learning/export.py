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
  checkpoints/gnn-<faithful|augmented>-<layout>-seed<N>.pt; for a domain other than the restaurant
  (whose committed names stay) the domain's PDDL name comes first: checkpoints/<domain>-rl-….pt and
  results/<domain>-training-….json.
- The key figures of a Q-learning run are what Appendix A.2 reports of it, read
  from its metrics.jsonl: at 50k, 100k, 250k and 500k steps (or the nearest logged
  step before), the success rate over the last 100 training tasks, the selected Q,
  the TD target and the share of the domain's preparation action ([preparation] action:
  refill-water in the restaurant, `refill_action`) in the last log window; the
  greedy evaluations (and, for a myopic run, demo_q_bias: Q above the myopic
  oracle's return on the demonstrations, the divergence alarm), and every one of them
  (`greedy_checks`: the learning curve by which a step count is judged); the largest selected
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
  results/dataset-gnn-<faithful|augmented>-<layout>.json (for another domain than the restaurant
  the domain's name first, as for checkpoints); there is no checkpoint.

Exporting never loses what is committed. Everything is read, computed and checked before
anything is written (a run without its metrics.jsonl leaves the committed checkpoint as it
was). A checkpoint or figures file already at the output is replaced only by the export of
the same run (its domain and every training setting alike, the run folder and the step
count among them: a run that trained on since is updated) and is kept byte for byte when it
is already this export (the sha256 that results files record of it still holds); another
run's, or a file that is no export, is a one-line error naming the file and what differs,
unless --force. The default names are made of values read from the run's files (its
settings' horizon, layout and seed, a GNN's layout, a dataset's layout), each checked to
name a file in its folder. A run still being trained is refused: its trainer holds the run
folder's lock (`learning.q.training.train_run`), and the export holds it in turn, so no trainer
starts on the run mid-export. A run stopped before its configured step count is exported
as it is, with a one-line note on stderr.
"""

from __future__ import annotations

import json
import os
import sys
from collections import Counter
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from learning.plain import full_precision, to_half
from learning.q.checkpoints import DOMAIN_KEYS, read_checkpoint, save_checkpoint
from learning.q.training import LEGACY, Config, bound_suffix, file_in, file_name, read_metrics
from learning.q.value import value_function
from planning import cli
from planning.atomic import OutputLock, sha256, write_json
from planning.domain.compiler import compile_domain
from planning.errors import DomainError
from planning.parallel import results_provenance
from planning.world.preparation import Preparation
from planning.world.results import file_prefix

MILESTONES = (50_000, 100_000, 250_000, 500_000)
PRECISION = "float16"
PROBE_STATES = 1000  # (state, task) pairs on which a float16 checkpoint must act as its float32 source
TIE = 0.01  # Q gaps below this are ties (trained values are tens to hundreds)
CURVE_EVERY = 5_000  # steps between the rows of a run's exported curve
CURVE_KEYS = ("success_rate", "task_return", "selected_q", "td_target")  # Figure A.1's panels


def compact(payload: dict, source: str | None = None, half: bool = True) -> dict:
    """The agent-facing part of a Q-network checkpoint, float tensors in float16 (`read_checkpoint` casts them
    back); `half=False` keeps them in float32."""
    keep = {k: payload[k] for k in ("dims", "signature", *DOMAIN_KEYS, "step", "eval", "config") if k in payload}
    net, precision = (to_half(payload["net"]), PRECISION) if half else (payload["net"], "float32")
    return {**keep, "net": net, "precision": precision, **({"source_sha256": source} if source else {})}


def compact_gnn(payload: dict, source: str | None = None) -> dict:
    """A GNN checkpoint with its weights in float16 (`read_gnn_checkpoint` casts them back)."""
    return {
        **payload,
        "model": to_half(payload["model"]),
        "precision": PRECISION,
        **({"source_sha256": source} if source else {}),
    }


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


def payload_layout(payload: dict) -> str | None:
    """The layout a Q-learning checkpoint was trained on (its config, or the signature of an older run)."""
    return payload.get("config", {}).get("layout") or payload.get("signature", {}).get("layout")


def faithful_compact(payload: dict, source: str | None = None) -> tuple[dict, float]:
    """(compact checkpoint, float16's greedy loss): float16 weights where they change no greedy action by more
    than a tie (TIE), float32 otherwise (a network whose values are so large that float16's rounding moves
    them by more than their action gaps, as a diverged run's)."""
    cfg = payload.get("config", {})
    layout = payload_layout(payload)
    if not layout:
        raise DomainError("checkpoint", "names no layout (config or signature) to probe its float16 copy on")
    small = compact(payload, source)
    loss = greedy_loss(payload, small, compile_domain(cfg.get("domain", Config.domain), layout))
    return (small if loss < TIE else compact(payload, source, half=False)), loss


def split_metrics(path: Path) -> tuple[list[dict], list[dict]]:
    """(log rows, evaluation rows) of a run's metrics.jsonl."""
    rows, _ = read_metrics(path)
    return [r for r in rows if "eval" not in r], [r["eval"] for r in rows if "eval" in r]


def key_figures(logs: list[dict], evals: list[dict], refill: str | None = None) -> dict:
    """What Appendix A.2 reports of a run (see the module's docstring); `refill`: the action that draws on a
    preparation (the domain's [preparation] action, `planning.world.preparation`; None: no share is reported)."""
    if not logs:  # a run shorter than its log_every: nothing logged yet
        return {"steps": 0, "train_hours": 0.0}
    last = logs[-1]["step"]
    window = lambda r: r.get("action_share", {}).get(refill) if refill else None
    cumulative, done, prev = {}, 0.0, 0  # `refill` actions since step 0, over the steps
    for r in logs:
        done += (window(r) or 0.0) * (r["step"] - prev)
        prev = r["step"]
        cumulative[r["step"]] = (round(done / r["step"], 5) if r["step"] else 0.0) if refill else None
    at = {}
    for m in MILESTONES:
        before = [r for r in logs if r["step"] <= m]
        if m > last or not before:
            continue
        row = max(before, key=lambda r: r["step"])
        ev = [e for e in evals if e["step"] <= m]
        at[str(m)] = {
            "step": row["step"],
            "success_last_100": row["success_rate"],
            "selected_q": round(row["selected_q"], 3),
            "td_target": round(row["td_target"], 3),
            "refill_share": window(row),
            "refill_share_cumulative": cumulative[row["step"]],
            **({"greedy": _eval(ev[-1])} if ev else {}),
        }
    peak = max(logs, key=lambda r: abs(r["selected_q"]) if r["selected_q"] == r["selected_q"] else 0.0)
    best = max(evals, key=lambda e: (e["success_rate"], e["task_return"])) if evals else None
    seconds, prev = 0.0, 0
    for r in logs:  # each row's rate is measured over the steps since the row before
        if r.get("steps_per_s"):
            seconds += (r["step"] - prev) / r["steps_per_s"]
        prev = r["step"]
    top = max((window(r) or 0.0, r["step"]) for r in logs)
    top_cumulative = max(((share or 0.0), step) for step, share in cumulative.items())
    return {
        "steps": last,
        "refill_action": refill,
        "at": at,
        "best_greedy": _eval(best) if best else None,
        "greedy_checks": [_eval(e) for e in evals],
        "peak_selected_q": {"step": peak["step"], "selected_q": round(peak["selected_q"], 3)},
        "peak_refill_share": {"step": top[1], "share": top[0]} if refill else None,
        "peak_refill_share_cumulative": {"step": top_cumulative[1], "share": top_cumulative[0]} if refill else None,
        "train_hours": round(seconds / 3600, 3),
        "steps_per_s_median": _median([r["steps_per_s"] for r in logs if r.get("steps_per_s")]),
        "curve": [
            {
                "step": r["step"],
                **{k: _short(r[k]) for k in CURVE_KEYS if k in r},
                "refill_share_cumulative": cumulative[r["step"]],
            }
            for r in logs
            if r["step"] % CURVE_EVERY == 0 or r is logs[-1]
        ],
    }


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
    spread = lambda x, d: {
        k: round(float(f(x)), d)
        for k, f in (("mean", np.mean), ("min", np.min), ("median", np.median), ("max", np.max))
    }
    cfg = meta.get("config", {})
    return {
        "dataset": str(folder),
        "domain": meta.get("domain"),
        "layout": meta.get("layout"),
        "variant": "augmented" if cfg.get("augmented", "prepared" in kinds) else "faithful",
        "states": len(kinds),
        "kinds": dict(Counter(kinds)),
        "tasks": len(meta.get("tasks", [])),
        "features": len(meta.get("feature_names", [])),
        "config": cfg,
        "c_ap": spread(c_ap, 2),
        "label_seconds": spread(secs, 4),
        **{
            k: meta[k]
            for k in ("seconds_faithful_states", "seconds_collecting_and_labelling", "label_cpu_seconds")
            if k in meta
        },
    }


def is_gnn_run(run: Path) -> bool:
    """True for a learning.gnn_train run folder, False for a learning.dqn one (by its best.pt)."""
    from learning.gnn.model import is_gnn_checkpoint

    return is_gnn_checkpoint(run / "best.pt")


def default_names(run: Path, gnn: bool) -> tuple[str, str]:
    """(checkpoint, figures) default paths of a run folder (`gnn`: a learning.gnn_train run), made of values its
    best.pt records, each checked to name a file (a seed of '../x' writes nowhere else)."""
    best = run / "best.pt"
    if gnn:
        from learning.gnn.model import read_gnn_checkpoint

        p = read_gnn_checkpoint(best)
        cfg = p.get("config", {})
        try:
            augmented = json.loads((Path(cfg.get("data", "")) / "meta.json").read_text())["config"]["augmented"]
        except (OSError, KeyError, TypeError, json.JSONDecodeError):
            raise DomainError(
                run, f"cannot tell the dataset variant from {cfg.get('data')}/meta.json; pass --out and --figures"
            ) from None
        name = (
            f"gnn-{'augmented' if augmented else 'faithful'}-{file_name(p.get('layout'), best, 'layout')}"
            f"-seed{file_name(cfg.get('seed'), best, 'config.seed')}"
        )
    else:
        p = read_checkpoint(best)
        cfg = p.get("config", {})
        named = ("target_bound", "stream", "estimator") if bound_suffix(cfg) else ()
        for field in ("horizon", "layout", "seed", *(f for f in named if f in cfg)):
            file_name(cfg.get(field), best, f"config.{field}")
        name = f"rl-{rl_name(cfg)}"
    prefix = domain_prefix(p.get("domain") or (p.get("signature") or {}).get("domain"), best)
    return (
        str(file_in("checkpoints", f"{prefix}{name}.pt", best, "its settings")),
        str(file_in("results", f"{prefix}training-{name.removeprefix('rl-')}.json", best, "its settings")),
    )


def domain_prefix(domain: str | None, where) -> str:
    """What an exported file's name starts with: nothing for the restaurant (its committed names stay) or a
    file that names no domain, else the domain's PDDL name and a dash."""
    return file_prefix(None if domain is None else file_name(domain, where, "domain"))


def rl_name(cfg: dict, varied: str = "") -> str:
    """<horizon>-<layout>-seed<N>[varied][-bound-<bound>]: the name a Q-learning run's exported files share
    (checkpoints/rl-NAME.pt, results/training-NAME.json, results/rl-greedy-NAME.json); `varied` names a
    sweep's other settings."""
    return f"{cfg.get('horizon')}-{cfg.get('layout')}-seed{cfg.get('seed')}{varied}{bound_suffix(cfg)}"


# ---- replacing what is there ----------------------------------------------------------------
FIRST = ("out", "data", "steps", "epochs")  # what tells runs apart first: their folder, their length
LABELS = {"out": "run folder", "data": "dataset"}
OLD_FIGURE_KEYS = ("domain", "layout", "horizon", "seed", "gamma", *LEGACY)
"""What a Q-learning run's figures without a 'config' record of its settings, at top level ('domain' is its
domain folder there, 'run' its run folder; their 'steps' is the last step logged, not a setting)."""


def _norm(key: str, value):
    return os.path.normpath(value) if key in ("out", "data") and isinstance(value, str) else value


def config_difference(saved: dict, new: dict, keys=None) -> str | None:
    """The first training setting in which two runs differ ('run folder ..., not ...'), or None: the run
    folder (or a GNN's dataset) and the length first, then the others by name; a setting missing from a
    file written before it existed counts as what such runs had (LEGACY). `keys`: only those."""
    keys = sorted(
        set(saved) | set(new) if keys is None else keys, key=lambda k: (FIRST.index(k) if k in FIRST else len(FIRST), k)
    )
    for key in keys:
        a, b = (_norm(key, d.get(key, LEGACY.get(key))) for d in (saved, new))
        if a != b:
            return f"{LABELS.get(key, key)} {a!r}, not {b!r}"
    return None


def run_difference(saved: dict, new: dict, keys=None) -> str | None:
    """How the run a saved export (a compact checkpoint, a figures file) was made from differs from this one:
    its domain (its name; its content where both record a digest), its layout, then its settings
    (`config_difference`); None for the same run."""
    for key in ("domain", "layout"):
        a, b = saved.get(key), new.get(key)
        if a is not None and b is not None and a != b:
            return f"{key} {a!r}, not {b!r}"
    a, b = saved.get("domain_sha256"), new.get("domain_sha256")
    if a and b and a != b:
        old, mine = saved.get("domain_files") or {}, new.get("domain_files") or {}
        changed = sorted(n for n in set(old) | set(mine) if old.get(n) != mine.get(n))
        return f"other content of domain {new.get('domain')!r} (changed: {', '.join(changed) or 'unknown files'})"
    return config_difference(saved.get("config") or {}, new.get("config") or {}, keys)


def figures_run(figs: dict) -> tuple[dict, list | None]:
    """(what a key-figures file records of the run it describes, as `run_difference` compares it, the settings
    it records where it records only some): a dataset's folder counts as its run folder; a Q-learning run's
    figures without a 'config' keep some settings at top level (OLD_FIGURE_KEYS)."""
    if isinstance(figs.get("dataset"), str):
        return {**figs, "config": {**(figs.get("config") or {}), "out": figs["dataset"]}}, None
    if "config" in figs:
        return figs, None
    old = {"out": figs.get("run"), **{k: figs[k] for k in OLD_FIGURE_KEYS if k in figs}}
    return {"config": old}, sorted(old)


def may_write(path: Path, new: dict, force: bool, read, what: str, option: str) -> bool:
    """Whether to write `new` (a compact checkpoint, or key figures: `read` loads what is at `path` now) at
    `path`: yes where nothing is there, or with `force`; yes for the same run's export of other content (the
    run trained on); no where it is this very export already (a checkpoint of the same best.pt, figures equal
    but for their provenance: the file is kept as it is); a one-line DomainError for another run's, or a
    file that is no export. Checks only: nothing is written here."""
    if not path.exists() or force:
        return True
    try:
        saved = read(path)
    except DomainError as e:
        raise DomainError(
            path,
            f"is not a {what} this export would replace ({e.reason}); pass --force to "
            f"replace it, or {option} another file",
        ) from None
    if not isinstance(saved, dict):
        raise DomainError(
            path, f"is not a {what} this export would replace; pass --force to replace it, or {option} another file"
        )
    if "source_sha256" in new:
        diff = run_difference(saved, new)
        same = saved.get("source_sha256") == new["source_sha256"]
    else:
        old, keys = figures_run(saved)
        mine = figures_run(new)[0]
        diff = run_difference(old, mine, keys)
        same = _without_provenance(saved) == _without_provenance(json.loads(json.dumps(new)))
    if diff is not None:
        raise DomainError(
            path, f"the {what} of another run ({diff}); pass --force to replace it, or {option} another file"
        )
    return not same


def _without_provenance(figs: dict) -> dict:
    return {k: v for k, v in figs.items() if k != "provenance"}


def _read_json(path: Path) -> dict:
    try:
        return json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise DomainError(path, f"unreadable ({type(e).__name__})") from None


@contextmanager
def exporting(folder: Path, what: str = "run"):
    """Held while a folder is exported: its OutputLock. A run still being trained (its trainer holds the
    lock, `learning.q.training.train_run`) is refused with a one-line error, and no trainer starts on it
    mid-export; a folder this process may not write in has no trainer there and is read unlocked."""
    if not folder.is_dir():
        raise DomainError(folder, f"no such {what} folder")
    lock = OutputLock(folder, what)
    try:
        lock.__enter__()
    except DomainError:
        raise DomainError(
            folder, f"is still being written (a trainer holds the {what}); export it when it ends"
        ) from None
    except OSError:
        lock = None
    try:
        yield
    finally:
        if lock is not None:
            lock.__exit__(None, None, None)


def unfinished(run: Path, payload: dict, logs: list, evals: list) -> str | None:
    """'trained to step X of Y' for a run stopped before its configured step count (its last.pt's, else its
    best.pt's), else None."""
    done = max([r.get("step", 0) for r in logs] + [e.get("step", 0) for e in evals], default=0)
    cfg = payload.get("config", {})
    if (run / "last.pt").is_file():
        try:
            cfg = read_checkpoint(run / "last.pt").get("config", cfg)
        except DomainError:
            pass
    steps = cfg.get("steps")
    return f"trained to step {done:,} of {steps:,}" if isinstance(steps, int) and done < steps else None


# ---- exports ---------------------------------------------------------------------------------
def export_gnn(
    run: Path, out: Path, figures: Path | None, force: bool = False, written: list | None = None
) -> tuple[dict, dict]:
    """The compact GNN checkpoint and the run's summary.json (with where it came from); everything checked
    before anything is written (see the module's docstring). Returns (compact payload, figures); the files
    written go on `written` (those already this export are kept as they are)."""
    from learning.gnn.model import read_gnn_checkpoint, save_gnn_checkpoint

    with exporting(run):
        best = run / "best.pt"
        small = compact_gnn(read_gnn_checkpoint(best), sha256(best))
        try:
            summary = json.loads((run / "summary.json").read_text())
        except (OSError, json.JSONDecodeError) as e:
            raise DomainError(run / "summary.json", f"cannot read the run's summary ({type(e).__name__})") from None
        figs = {"run": str(run), "checkpoint": str(out), "checkpoint_epoch": small.get("epoch"), **summary}
        write = may_write(out, small, force, read_gnn_checkpoint, "GNN checkpoint", "--out")
        write_figs = figures is not None and (
            may_write(figures, figs, force, _read_json, "key figures", "--figures") or write
        )
        if write:
            save_gnn_checkpoint(out, small)
        if write_figs:
            write_json(figures, {**figs, "provenance": results_provenance(figs)})
    if written is not None:
        written += [path for path, done in ((out, write), (figures, write_figs)) if done]
    return small, figs


def export(
    run: Path, out: Path, figures: Path | None, force: bool = False, written: list | None = None
) -> tuple[dict, dict]:
    """Write the compact checkpoint (and the key figures); returns (compact payload, figures); the files written
    go on `written` (those already this export are kept as they are). Everything is read and checked before
    anything is written (see the module's docstring)."""
    run, out = Path(run), Path(out)
    with exporting(run):
        best = run / "best.pt"
        payload = read_checkpoint(best)
        logs, evals = split_metrics(run / "metrics.jsonl")
        small, loss = faithful_compact(payload, sha256(best))
        cfg = payload.get("config", {})
        prep = Preparation.of(compile_domain(cfg.get("domain", Config.domain), payload_layout(payload)))
        recorded = {k: payload[k] for k in DOMAIN_KEYS if k in payload} or {
            "domain": payload.get("signature", {}).get("domain")
        }  # a run from before domains were recorded
        figs = {
            "run": str(run),
            "checkpoint": str(out),
            "checkpoint_step": payload.get("step"),
            "checkpoint_precision": small["precision"],
            "float16_greedy_loss": loss,
            **recorded,
            **{k: cfg.get(k) for k in ("layout", "horizon", "seed", "steps", "gamma")},
            **{k: cfg.get(k, was) for k, was in LEGACY.items()},
            "config": cfg,
            **key_figures(logs, evals, prep.action if prep else None),
        }
        write = may_write(out, small, force, read_checkpoint, "checkpoint", "--out")
        write_figs = figures is not None and (
            may_write(Path(figures), figs, force, _read_json, "key figures", "--figures") or write
        )
        short = unfinished(run, payload, logs, evals)
        if short:
            print(
                f"{run}: unfinished, {short} (stopped before its end; rerun its training command to finish "
                "it); exported as it is",
                file=sys.stderr,
            )
        if write:
            save_checkpoint(out, small)
        if write_figs:
            write_json(figures, {**figs, "provenance": results_provenance(figs)})
    if written is not None:
        written += [path for path, done in ((out, write), (figures, write_figs)) if done]
    return small, figs


def _done(path: Path, written: list) -> str:
    return f"wrote {path}" if path in written else f"kept {path} (already this export)"


def main() -> None:
    p = cli.parser(
        __doc__.splitlines()[0],
        domain=False,
        layout=False,
        helps={
            "out": "compact checkpoint (default: checkpoints/rl-<horizon>-<layout>-seed<N>.pt, "
            "checkpoints/gnn-<variant>-<layout>-seed<N>.pt)"
        },
    )
    p.add_argument(
        "run",
        help="a learning.dqn run folder (best.pt, metrics.jsonl), a learning.gnn_train one "
        "(best.pt, summary.json) or a learning.gnn_dataset folder (meta.json)",
    )
    p.add_argument("--figures", help="key figures JSON (default: results/training-<checkpoint name without rl->.json)")
    p.add_argument(
        "--force",
        action="store_true",
        help="replace a checkpoint or figures file exported from another run (or one that is no export)",
    )

    def run():
        args = p.parse_args()
        folder = Path(args.run)
        if not folder.is_dir():
            raise DomainError(folder, "no such run or dataset folder")
        if is_dataset(folder):
            if args.out:
                raise DomainError("--out", "a dataset has no checkpoint; --figures names its key figures")
            with exporting(folder, "dataset"):
                figs = dataset_figures(folder)
                meta = folder / "meta.json"
                name = (
                    f"{domain_prefix(figs.get('domain'), meta)}dataset-gnn-{figs['variant']}-"
                    f"{file_name(figs['layout'], meta, 'layout')}.json"
                )
                figures = Path(args.figures or file_in("results", name, meta, "layout"))
                cli.check_writable(figures)
                written = (
                    [figures] if may_write(figures, figs, args.force, _read_json, "key figures", "--figures") else []
                )
                if written:
                    write_json(figures, {**figs, "provenance": results_provenance(figs)})
            print(
                f"{_done(figures, written)}: {figs['states']:,} states ("
                + ", ".join(f"{v:,} {k}" for k, v in figs["kinds"].items())
                + f"), mean C_AP {figs['c_ap']['mean']:,.1f}"
            )
            return
        gnn = is_gnn_run(folder)
        names = default_names(folder, gnn) if not (args.out and args.figures) else (args.out, args.figures)
        out, figures = Path(args.out or names[0]), Path(args.figures or names[1])
        cli.check_writable(out)
        cli.check_writable(figures)
        if gnn:
            written = []
            small, figs = export_gnn(folder, out, figures, force=args.force, written=written)
            print(
                f"{_done(out, written)} ({out.stat().st_size / 1e3:.0f} KB, {PRECISION}, epoch {small.get('epoch')}, "
                f"validation L1 {figs['best_val_l1']:.2f}) and {_done(figures, written)}"
            )
            return
        written = []
        small, figs = export(folder, out, figures, force=args.force, written=written)
        at = figs.get("at", {})
        kept = (
            ""
            if small["precision"] == PRECISION
            else (
                f": float16 would give up {figs['float16_greedy_loss']:,.4g} of value on a probe state's greedy action"
            )
        )
        print(
            f"{_done(out, written)} ({out.stat().st_size / 1e3:.0f} KB, {small['precision']}{kept}, step "
            f"{small.get('step')}) and {_done(figures, written)}: {figs['steps']:,} steps in {figs['train_hours']} h; "
            "success (last 100) " + ", ".join(f"{int(k) // 1000}k {v['success_last_100']:.2f}" for k, v in at.items())
        )

    cli.run(run)


if __name__ == "__main__":
    main()
