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
(`learning.gnn.graph`); `edge_dim=None`, the default and the thesis's setting,
ignores it, and `edge_dim=len(relations)` uses it.

`InferenceGNN` is the same function for valuation in a search. Every graph of a
layout has the same nodes in the same order, and most of a node's 412 features
(its name's embedding, its type, static roles) never change; so the first
layer's four linear maps (joined in one matrix) are applied once to the
encoder's base graph, and per batch only to the columns where the batch differs
from it: x W = base W + (x - base)[:, changed] W[changed, :]. Batch
normalisation is folded into a scale and a shift, the attention softmax is done
with scatter operations.

Checkpoints are plain dicts of tensors and numbers (`learning.plain`), written
atomically and loaded with weights_only=True (`read_gnn_checkpoint`). A checkpoint,
like the dataset it was trained on, names its domain and layout, and since
`planning.domain.identity` the digest of the domain content it was made from:
wherever one is loaded it must be of the layout it is used with (`check_made_for`).
"""

from __future__ import annotations

import io
import sys
from pathlib import Path

import torch
from torch import nn

from planning.atomic import write_bytes
from planning.errors import DomainError

THESIS_FEATURES = 399
THESIS_PARAMETERS = 152_897
KIND = "gnn-cap"  # the payload's "kind": what read_gnn_checkpoint accepts


class GNNCostModel(nn.Module):
    """Graph -> scalar Ĉ_AP: 4 x (TransformerConv -> BatchNorm -> LeakyReLU), mean + add pool, linear head."""

    def __init__(
        self,
        in_features: int,
        width: int = 64,
        layers: int = 4,
        edge_dim: int | None = None,
        negative_slope: float = 0.01,
    ):
        from torch_geometric.nn import TransformerConv

        super().__init__()
        self.dims = {
            "in_features": int(in_features),
            "width": int(width),
            "layers": int(layers),
            "edge_dim": None if edge_dim is None else int(edge_dim),
            "negative_slope": float(negative_slope),
        }
        sizes = [in_features] + [width] * layers
        self.convs = nn.ModuleList(
            TransformerConv(a, b, heads=1, edge_dim=edge_dim) for a, b in zip(sizes[:-1], sizes[1:])
        )
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
        return self(
            data.x, data.edge_index, batch, getattr(data, "edge_attr", None), num_graphs=getattr(data, "num_graphs", 1)
        )


class InferenceGNN:
    """`GNNCostModel.forward` in eval mode, without autograd or PyG dispatch: same inputs, same Ĉ_AP to
    float rounding (a test holds it to the module's).

    `base`: (nodes, features) the graph every input graph's x differs from in a few columns
    (`learning.gnn.graph.GraphEncoder.base`); a batch of whole graphs of that many nodes each then
    pays the first layer only on the columns that differ. Without it, the plain product."""

    def __init__(self, net: GNNCostModel, base=None):
        self.slope = net.dims["negative_slope"]
        self.layers = []
        with torch.no_grad():
            for conv, norm in zip(net.convs, net.norms):
                lins = [conv.lin_query, conv.lin_key, conv.lin_value, conv.lin_skip]
                w = torch.cat([lin.weight for lin in lins]).t().contiguous()
                b = torch.cat([lin.bias for lin in lins])
                edge = None if conv.lin_edge is None else conv.lin_edge.weight.t().contiguous()
                scale = norm.weight / torch.sqrt(norm.running_var + norm.eps)
                shift = norm.bias - norm.running_mean * scale
                self.layers.append((w, b, edge, conv.out_channels, scale, shift))
            self.head_w = net.head.weight.t().contiguous()
            self.head_b = net.head.bias.clone()
            self.base = None if base is None else torch.as_tensor(base, dtype=torch.float32)
            if self.base is not None:
                w, b = self.layers[0][:2]
                self.base_first = torch.addmm(b, self.base, w)  # the base graph's first-layer maps

    def _first(self, x, w, b):
        """The first layer's joined linear maps of x; through the base graph where x is whole copies of it."""
        base = self.base
        if base is None or x.shape[0] % base.shape[0] or x.shape[1] != base.shape[1]:
            return torch.addmm(b, x, w)
        n, f = base.shape
        delta = (x.view(-1, n, f) - base).view(-1, f)
        cols = delta.any(0).nonzero().squeeze(1)
        return ((delta[:, cols] @ w[cols]).view(-1, n, w.shape[1]) + self.base_first).view(-1, w.shape[1])

    def __call__(self, x, edge_index, batch, edge_attr=None, num_graphs: int | None = None) -> torch.Tensor:
        with torch.inference_mode():
            src, dst = edge_index[0], edge_index[1]
            n = x.shape[0]
            for depth, (w, b, edge, c, scale, shift) in enumerate(self.layers):
                q, k, v, root = (self._first(x, w, b) if depth == 0 else torch.addmm(b, x, w)).split(c, dim=1)
                kj, vj = k[src], v[src]
                if edge is not None:
                    e = edge_attr @ edge
                    kj, vj = kj + e, vj + e
                alpha = (q[dst] * kj).sum(1) / c**0.5
                top = torch.full((n,), float("-inf")).scatter_reduce_(0, dst, alpha, "amax")
                ex = (alpha - top[dst]).exp()
                den = torch.zeros(n).index_add_(0, dst, ex)
                msg = vj * (ex / (den[dst] + 1e-16)).unsqueeze(1)  # torch_geometric.utils.softmax's 1e-16
                h = root.index_add(0, dst, msg) * scale + shift
                x = torch.where(h >= 0, h, h * self.slope)
            g = num_graphs if num_graphs is not None else int(batch.max()) + 1
            total = torch.zeros(g, x.shape[1]).index_add_(0, batch, x)
            count = torch.bincount(batch, minlength=g).clamp_(min=1).unsqueeze(1)
            return torch.addmm(self.head_b, total / count + total, self.head_w).squeeze(-1)


def check_made_for(path, saved: dict, model, what: str = "GNN model") -> None:
    """A one-line DomainError naming `path` if a GNN checkpoint or dataset (`saved`: its payload or
    meta.json) records another domain or layout than `model`'s: the graphs of another layout have
    other nodes, so its estimates would be figures of nothing. A recorded digest of other content
    of the same domain and layout is a one-line warning: the graphs still fit, the labels the model
    learned may not. A file that records neither (an early checkpoint) is taken as it is."""
    from planning.domain.identity import mismatch

    domain, layout = saved.get("domain"), saved.get("layout")
    if domain not in (None, model.name) or layout not in (None, model.layout):
        raise DomainError(
            path,
            f"a {what} of {domain or 'an unnamed domain'} {layout or '(no layout)'}, not of "
            f"{model.name} {model.layout}",
        )
    diff = mismatch(saved, model)
    if diff is not None:
        print(
            f"warning: {path}: a {what} made from {diff}; its C_AP figures may not hold for this content",
            file=sys.stderr,
        )


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
    if not isinstance(payload, dict) or payload.get("kind") != KIND or "model" not in payload or "dims" not in payload:
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
