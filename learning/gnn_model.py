"""The one-task GNN estimator of C_AP (thesis Appendix A.1, after Talukder et al. 2024).

Four TransformerConv layers (Shi et al. 2021) of width 64 with one attention
head, each followed by batch normalisation and a LeakyReLU; the graph embedding
is the *sum* of global mean pooling and global add pooling (one 64-vector, not
their concatenation); a linear head maps it to the scalar C_AP in PDDL cost
units. On the thesis's 399 input features this is 152,897 parameters:

    conv 1      4 x (399 x 64 + 64)  = 102,400   (query, key, value, skip: weight + bias)
    conv 2..4   3 x 4 x (64 x 64 + 64) = 49,920
    batch norm  4 x 128              =     512   (weight + bias; running stats are buffers)
    head        64 + 1               =      65
                                       152,897

which fixes the two readings the text leaves open: the thesis's layers take no
edge features (an `edge_dim` adds 64 x edge_dim per layer, without bias) and
the two pools are added, not concatenated (concatenation would make the head
129 parameters). Our graphs carry a one-hot relation per edge
(`learning.graph`); `edge_dim=None`, the default and the thesis's setting,
ignores it, and `edge_dim=len(relations)` uses it.

Checkpoints are plain dicts of tensors and numbers (`learning.plain`), written
atomically and loaded with weights_only=True (`read_gnn_checkpoint`).
"""
from __future__ import annotations

import io
from pathlib import Path

import torch
from torch import nn

from planning.atomic import write_bytes
from planning.errors import DomainError

THESIS_FEATURES = 399
THESIS_PARAMETERS = 152_897
KIND = "gnn-cap"            # the payload's "kind": what read_gnn_checkpoint accepts


class GNNCostModel(nn.Module):
    """Graph -> scalar Ĉ_AP: 4 x (TransformerConv -> BatchNorm -> LeakyReLU), mean + add pool, linear head."""

    def __init__(self, in_features: int, width: int = 64, layers: int = 4, edge_dim: int | None = None,
                 negative_slope: float = 0.01):
        from torch_geometric.nn import TransformerConv

        super().__init__()
        self.dims = {"in_features": int(in_features), "width": int(width), "layers": int(layers),
                     "edge_dim": None if edge_dim is None else int(edge_dim),
                     "negative_slope": float(negative_slope)}
        sizes = [in_features] + [width] * layers
        self.convs = nn.ModuleList(TransformerConv(a, b, heads=1, edge_dim=edge_dim)
                                   for a, b in zip(sizes[:-1], sizes[1:]))
        self.norms = nn.ModuleList(nn.BatchNorm1d(width) for _ in range(layers))
        self.act = nn.LeakyReLU(negative_slope)
        self.head = nn.Linear(width, 1)

    def forward(self, x, edge_index, batch, edge_attr=None, num_graphs: int | None = None):
        """(num_graphs,) Ĉ_AP of a batch of graphs (`batch`: each node's graph)."""
        from torch_geometric.nn import global_add_pool, global_mean_pool

        e = edge_attr if self.dims["edge_dim"] is not None else None
        for conv, norm in zip(self.convs, self.norms):
            x = self.act(norm(conv(x, edge_index, e)))
        g = global_mean_pool(x, batch, num_graphs) + global_add_pool(x, batch, num_graphs)
        return self.head(g).squeeze(-1)

    def predict(self, data):
        """Ĉ_AP of a torch_geometric Batch (or one Data)."""
        batch = getattr(data, "batch", None)
        if batch is None:
            batch = torch.zeros(data.num_nodes, dtype=torch.long)
        return self(data.x, data.edge_index, batch, getattr(data, "edge_attr", None),
                    num_graphs=getattr(data, "num_graphs", 1))


def parameter_count(model: nn.Module) -> int:
    """Trainable parameters (batch norm running statistics are buffers, not counted)."""
    return sum(p.numel() for p in model.parameters() if p.requires_grad)


def save_gnn_checkpoint(path, payload: dict) -> Path:
    """Write a GNN checkpoint atomically in plain types (tensors, numbers, strings, lists, dicts)."""
    from learning.plain import to_plain

    buf = io.BytesIO()
    torch.save(to_plain({**payload, "kind": KIND}), buf)
    return write_bytes(path, buf.getvalue())


def is_gnn_checkpoint(path) -> bool:
    """True for a learning.gnn_train checkpoint, False for any other checkpoint (read safely)."""
    from learning.plain import load_plain

    payload = load_plain(path, "checkpoint")
    return isinstance(payload, dict) and payload.get("kind") == KIND


def read_gnn_checkpoint(path) -> dict:
    """A GNN checkpoint's payload, loaded with weights_only=True; anything else is a one-line DomainError."""
    from learning.plain import from_plain, full_precision, load_plain

    payload = load_plain(path, "GNN checkpoint")
    if not isinstance(payload, dict) or payload.get("kind") != KIND or "model" not in payload \
            or "dims" not in payload:
        raise DomainError(path, "not a GNN checkpoint (learning.gnn_train writes them)")
    return full_precision(from_plain(payload), "model")


def load_gnn(path) -> tuple[GNNCostModel, dict]:
    """(the model in eval mode, its payload) from a checkpoint."""
    payload = read_gnn_checkpoint(path)
    dims = payload["dims"]
    try:
        net = GNNCostModel(**dims)
        net.load_state_dict(payload["model"])
    except (TypeError, RuntimeError, KeyError) as e:
        raise DomainError(path, f"GNN checkpoint does not fit its own dimensions ({type(e).__name__})") from None
    net.eval()
    return net, payload
