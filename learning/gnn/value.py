"""The one-task GNN as a value of the protocol (`planning.value`).

    v_ap(states)        = -Ĉ_AP(s) / cost_scale     the GNN's anticipatory cost, negated
    q_max(states, task) = the same estimate         (the Bellman lane keys on it too)

Ĉ_AP is in PDDL cost units; dividing by the domain's [reward] cost_scale puts it
in the units of the Bellman–Novelty search's prefix returns (which are divided
by the same scale), so the Bellman key G + γ^d q_max adds like to like. The
order the value induces, which is all the terminal selection reads, is that of
-Ĉ_AP. The estimate is undiscounted: gamma = 1.

A batch of states is encoded (`learning.gnn.graph.GraphEncoder`) and valued in one
forward pass (`learning.gnn.model.InferenceGNN`: the module's function, with the
first layer paid only on the columns where the states differ from the base
graph); the estimates are cached per state, so a search that values a state
twice runs the network once. The gnn-guided agent searches with it (`learning.agents.guided`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from learning.gnn.model import InferenceGNN, check_made_for, load_gnn
from learning.reward import cost_scale
from planning.errors import DomainError

RECORDED = "-C_AP / cost_scale (learning.gnn_value)"
"""What a results config records as this value. The committed gnn-guided results hold this label, which names
the module by the path it had when they were made; a rerun's config must equal theirs, so the label stays."""
CHUNK = 128  # graphs per forward pass: per state, InferenceGNN is fastest at 32-128 (0.19 ms) and slows
# past them (0.32 ms at 512, 0.56 ms at 2,000; three-room, one thread)


def collate(arrays: list) -> tuple:
    """One batch from GraphEncoder.arrays outputs: (x, edge_index, edge_attr, batch) tensors."""
    xs, idx, attrs, batch, offset = [], [], [], [], 0
    for g, (x, index, attr) in enumerate(arrays):
        xs.append(x)
        idx.append(index + offset)
        attrs.append(attr)
        batch.append(np.full(len(x), g, dtype=np.int64))
        offset += len(x)
    return (
        torch.from_numpy(np.concatenate(xs)),
        torch.from_numpy(np.concatenate(idx, axis=1)),
        torch.from_numpy(np.concatenate(attrs)),
        torch.from_numpy(np.concatenate(batch)),
    )


class GNNValue:
    """The GNN's C_AP estimate as a batched value: V_AP = q_max = -Ĉ_AP / cost_scale."""

    def __init__(
        self, checkpoint, model, encoder=None, scale: float | None = None, gamma: float = 1.0, cache_size: int = 500_000
    ):
        """`checkpoint`: a learning.gnn_train checkpoint path, or a (GNNCostModel, payload) pair.
        `encoder`: the layout's GraphEncoder (default: built from the model, MiniLM name embeddings)."""
        from learning.gnn.graph import GraphEncoder

        if isinstance(checkpoint, (str, Path)):
            self.net, self.payload = load_gnn(checkpoint)
            self.checkpoint = str(checkpoint)
        else:
            self.net, self.payload = checkpoint
            self.checkpoint = None
        where = self.checkpoint or "GNN model"
        check_made_for(where, self.payload, model)  # before the encoder: a wrong layout costs nothing
        self.net.eval()
        self.encoder = encoder or GraphEncoder(model)
        names = self.payload.get("feature_names")
        if names and list(names) != list(self.encoder.feature_names):
            raise DomainError(
                where,
                f"trained on {len(names)} node features of layout "
                f"{self.payload.get('layout')}, not the {self.encoder.num_features} of "
                f"{model.name} {model.layout}",
            )
        if self.net.dims["in_features"] != self.encoder.num_features:
            raise DomainError(
                where,
                f"takes {self.net.dims['in_features']} node features, the layout's graphs "
                f"have {self.encoder.num_features}",
            )
        self.inference = InferenceGNN(self.net, self.encoder.base)
        self.model = model
        self.gamma = float(gamma)
        self.scale = float(scale if scale is not None else cost_scale(model))
        self.cache_size = cache_size
        self._cache: dict[int, float] = {}
        self.forward_calls = 0
        self.forward_states = 0

    @classmethod
    def load(cls, path, model) -> "GNNValue":
        """The value registry's hook (`learning.values`): the value of a learning.gnn_train checkpoint."""
        if path is None:
            raise DomainError("--value", "gnn needs a checkpoint: gnn:PATH")
        return cls(path, model)

    @staticmethod
    def record(path) -> dict:
        """What a results file records of the checkpoint: its training summary and what the value is."""
        return {**model_summary(path), "value": RECORDED}

    def c_ap(self, states: list) -> np.ndarray:
        """Ĉ_AP per state in PDDL cost units; the states not seen before in forward passes of at most
        CHUNK graphs (one for a search's batch)."""
        need = [s for s in dict.fromkeys(states) if s not in self._cache]
        if len(self._cache) + len(need) > self.cache_size:  # full: keep only what this call asks for
            self._cache = {s: self._cache[s] for s in states if s in self._cache}
        for i in range(0, len(need), CHUNK):
            part = need[i : i + CHUNK]
            x, index, attr, batch = collate([self.encoder.arrays(s) for s in part])
            y = self.inference(x, index, batch, attr, num_graphs=len(part)).numpy()
            self.forward_calls += 1
            self.forward_states += len(part)
            self._cache.update(zip(part, y.astype(float).tolist()))
        return np.array([self._cache[s] for s in states], dtype=float)

    def v_ap(self, states: list) -> np.ndarray:
        return -self.c_ap(states) / self.scale

    def q_max(self, states: list, task) -> np.ndarray:
        return self.v_ap(states)  # a one-task estimate: the same for every current task


def model_summary(path) -> dict:
    """What a results file records of a GNN checkpoint."""
    from learning.gnn.model import read_gnn_checkpoint

    p = read_gnn_checkpoint(path)
    cfg = p.get("config", {})
    return {
        "model": str(path),
        "epoch": p.get("epoch"),
        "val_l1": p.get("val_l1"),
        "layout": p.get("layout"),
        "data": cfg.get("data"),
        "seed": cfg.get("seed"),
        "edge_features": cfg.get("edge_features"),
    }
