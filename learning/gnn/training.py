"""Training the one-task GNN estimator of C_AP (thesis Appendix A.1).

L1 regression on C_AP in PDDL cost units (no target normalisation), Adagrad at
learning rate 0.01, batches of 8 graphs, the learning rate halved every 1,000
batches, an 80/20 train/validation split drawn from the run seed; the
checkpoint with the lowest validation L1 is kept (OUT/best.pt). The thesis
trains 40 epochs on the faithful dataset and 12 on the augmented one, seeds 0,
4, 8 and 16.

    python -m learning.gnn_train --data runs/gnn/three-room-faithful --seed 0 [--epochs 40] --out DIR

OUT/last.pt (model, optimizer, scheduler, metrics so far) is written atomically
after every epoch, so an interrupted run resumes where it stopped; OUT/best.pt
is the model the agents load (`learning.gnn.model.load_gnn`); OUT/metrics.jsonl
has one line per epoch (train and validation L1, learning rate, seconds). Every
checkpoint holds plain types only and loads with weights_only=True. The batch
order of epoch e is drawn from (seed, e), so a resumed run is the run that was
not interrupted.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from learning.gnn.model import GNNCostModel, parameter_count, read_gnn_checkpoint, save_gnn_checkpoint
from planning.atomic import write_text
from planning.errors import DomainError


@dataclass
class TrainConfig:
    """The thesis's settings (Appendix A.1); `epochs` 40 for the faithful dataset, 12 for the augmented one."""

    data: str = ""
    seed: int = 0
    epochs: int = 40
    lr: float = 0.01
    batch_size: int = 8
    lr_step: int = 1000  # batches between halvings
    lr_decay: float = 0.5
    val_fraction: float = 0.2
    width: int = 64
    layers: int = 4
    edge_features: bool = False  # the thesis's layers take none; ours may use the relation one-hot


RESUME_KEYS = (
    "data",
    "seed",
    "lr",
    "batch_size",
    "lr_step",
    "lr_decay",
    "val_fraction",
    "width",
    "layers",
    "edge_features",
)
"""A last.pt is resumed only by a run that agrees on these (the number of epochs may grow)."""


def split(n: int, seed: int, val_fraction: float = 0.2) -> tuple[np.ndarray, np.ndarray]:
    """(train indices, validation indices): a permutation drawn from the seed, the first 20% validation."""
    perm = np.random.default_rng(seed).permutation(n)
    n_val = int(round(val_fraction * n))
    if n >= 2:
        n_val = min(max(n_val, 1), n - 1)
    return np.sort(perm[n_val:]), np.sort(perm[:n_val])


def build_model(cfg: TrainConfig, n_features: int, n_relations: int) -> GNNCostModel:
    torch.manual_seed(cfg.seed)
    return GNNCostModel(n_features, cfg.width, cfg.layers, n_relations if cfg.edge_features else None)


def evaluate_l1(net: GNNCostModel, subset, batch_size: int = 64) -> float:
    """Mean |Ĉ_AP - C_AP| over a dataset subset, the model in eval mode."""
    from torch_geometric.loader import DataLoader

    if len(subset) == 0:
        return float("nan")
    net.eval()
    total = 0.0
    with torch.no_grad():
        for b in DataLoader(subset, batch_size=batch_size, shuffle=False):
            total += float((net.predict(b) - b.y.view(-1)).abs().sum())
    return total / len(subset)


IDENTITY_KEYS = ("domain", "domain_sha256", "domain_files")
"""What a checkpoint records of the domain its dataset was made from (`planning.domain.identity`)."""


def _payload(net, cfg, meta, epoch, val_l1, train_idx, val_idx) -> dict:
    return {
        "model": net.state_dict(),
        "dims": dict(net.dims),
        "config": asdict(cfg),
        "epoch": epoch,
        "val_l1": val_l1,
        **{k: meta[k] for k in IDENTITY_KEYS if meta.get(k) is not None},
        "layout": meta.get("layout"),
        "feature_names": list(meta.get("feature_names", [])),
        "relation_names": list(meta.get("relation_names", [])),
        "n_train": int(len(train_idx)),
        "n_val": int(len(val_idx)),
        "parameters": parameter_count(net),
    }


def train(cfg: TrainConfig, out, progress: bool = True, dataset=None) -> dict:
    """Train (or resume) into `out`; returns the summary also written to OUT/summary.json."""
    from torch_geometric.loader import DataLoader

    from learning.gnn.dataset import load_dataset

    out = Path(out)
    ds = dataset if dataset is not None else load_dataset(cfg.data)
    meta = getattr(ds, "meta", {})
    if len(ds) < 2:
        raise DomainError(cfg.data, f"{len(ds)} labelled states: too few to split into training and validation")
    n_features = ds[0].x.shape[1]
    n_relations = ds[0].edge_attr.shape[1] if getattr(ds[0], "edge_attr", None) is not None else 0
    if cfg.edge_features and n_relations == 0:
        raise DomainError(cfg.data, "--edge-features: the dataset's graphs carry no edge attributes")
    train_idx, val_idx = split(len(ds), cfg.seed, cfg.val_fraction)
    train_set, val_set = ds[torch.from_numpy(train_idx)], ds[torch.from_numpy(val_idx)]

    net = build_model(cfg, n_features, n_relations)
    opt = torch.optim.Adagrad(net.parameters(), lr=cfg.lr)
    sched = torch.optim.lr_scheduler.StepLR(opt, step_size=cfg.lr_step, gamma=cfg.lr_decay)
    history: list[dict] = []
    best_val, start = float("inf"), 0
    last = out / "last.pt"
    if last.is_file():
        saved = read_gnn_checkpoint(last)
        mine = {k: v for k, v in asdict(cfg).items() if k in RESUME_KEYS}
        theirs = {k: saved.get("config", {}).get(k) for k in RESUME_KEYS}
        if mine != theirs:
            diff = ", ".join(f"{k}: {theirs[k]} there, {mine[k]} here" for k in RESUME_KEYS if mine[k] != theirs[k])
            raise DomainError(last, f"a run with other settings ({diff}); choose another --out")
        net.load_state_dict(saved["model"])
        opt.load_state_dict(saved["optimizer"])
        sched.load_state_dict(saved["scheduler"])
        history, best_val, start = list(saved["history"]), float(saved["best_val"]), int(saved["epoch"])
    bar = tqdm(
        total=cfg.epochs,
        initial=min(start, cfg.epochs),
        desc=f"gnn seed {cfg.seed}",
        unit="epoch",
        disable=not progress,
    )
    for epoch in range(start, cfg.epochs):
        t0 = time.perf_counter()
        net.train()
        gen = torch.Generator().manual_seed(cfg.seed * 100_003 + epoch)  # the epoch's batch order
        total, n = 0.0, 0
        for b in DataLoader(train_set, batch_size=cfg.batch_size, shuffle=True, generator=gen):
            opt.zero_grad()
            loss = (net.predict(b) - b.y.view(-1)).abs().mean()
            loss.backward()
            opt.step()
            sched.step()
            total += float(loss.detach()) * b.num_graphs
            n += b.num_graphs
        val_l1 = evaluate_l1(net, val_set)
        seconds = time.perf_counter() - t0
        row = {
            "epoch": epoch + 1,
            "train_l1": round(total / max(n, 1), 4),
            "val_l1": round(val_l1, 4),
            "lr": opt.param_groups[0]["lr"],
            "batches": int(sched.last_epoch),
            "seconds": round(seconds, 3),
        }
        if val_l1 < best_val:
            best_val = val_l1
            row["best"] = True
            save_gnn_checkpoint(out / "best.pt", _payload(net, cfg, meta, epoch + 1, val_l1, train_idx, val_idx))
        history.append(row)
        save_gnn_checkpoint(
            last,
            {
                **_payload(net, cfg, meta, epoch + 1, val_l1, train_idx, val_idx),
                "optimizer": opt.state_dict(),
                "scheduler": sched.state_dict(),
                "history": history,
                "best_val": best_val,
            },
        )
        write_text(out / "metrics.jsonl", "".join(json.dumps(r) + "\n" for r in history))
        bar.set_postfix(train_l1=f"{row['train_l1']:.1f}", val_l1=f"{val_l1:.1f}", best=f"{best_val:.1f}")
        bar.update(1)
    bar.close()
    seconds = [r["seconds"] for r in history]
    summary = {
        "config": asdict(cfg),
        "epochs": len(history),
        "best_val_l1": best_val,
        "best_epoch": next((r["epoch"] for r in history if r["val_l1"] == round(best_val, 4)), None),
        "final_val_l1": history[-1]["val_l1"] if history else None,
        "seconds_per_epoch": round(float(np.mean(seconds)), 3) if seconds else None,
        "n_train": int(len(train_idx)),
        "n_val": int(len(val_idx)),
        "parameters": parameter_count(net),
        "dataset": {k: meta.get(k) for k in ("domain", "layout", "n", "domain_sha256")},
    }
    from planning.atomic import write_json

    write_json(out / "summary.json", summary)
    return summary
