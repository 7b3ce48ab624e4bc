"""The factored autoregressive dueling Q-network (thesis §4.1.1, Figure 4.2).

Q(s, τ, a) = V(s, τ) + Σ_d Ā_d(s, τ, a_1..a_{d-1}; a_d): a shared encoder of the
observation, a state-value head and one advantage head per action component.
Head d sees the state embedding and learned embeddings of the earlier
components; its advantages are centred over the values of component d that are
valid given that prefix. Valid tuples in a state are exactly the factored labels
of its valid ground actions (plus AUTO, see `learning.encoding`), so Q is
computed for every ground action at once and the greedy action is the argmax
over the valid ones: exact enumeration, batched over many (state, task) pairs.

The network trains in torch (`learning.q.training`, its targets in
`learning.q.targets`); it acts and values states through numpy and compiled
copies of its weights (`learning.q.inference`), bound to a layout as the value
of the protocol (`learning.q.value`).
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from learning.encoding import Encoding


class ActionTable:
    """Static index tables of the factored action space: per head, the distinct prefixes and gathers."""

    def __init__(self, labels: np.ndarray, vocab_sizes: list):
        self.sizes = list(vocab_sizes)
        self.prefixes, self.flat, self.scatter, self.uses, self.pid, self.val = [], [], [], [], [], []
        n = labels.shape[0]
        for d in range(labels.shape[1]):
            keys = [tuple(r) for r in labels[:, :d].tolist()]
            uniq = list(dict.fromkeys(keys))
            pid = np.array([uniq.index(k) for k in keys], dtype=np.int64)
            flat = pid * self.sizes[d] + labels[:, d]
            # scatter[a, p*V+v] = 1: action a is a tuple with prefix p and value v at head d
            sc = np.zeros((n, len(uniq) * self.sizes[d]), dtype=np.float32)
            sc[np.arange(n), flat] = 1.0
            uses = np.zeros((n, len(uniq)), dtype=np.float32)  # action a has prefix p
            uses[np.arange(n), pid] = 1.0
            self.prefixes.append(torch.tensor(np.array(uniq, dtype=np.int64).reshape(len(uniq), d)))
            self.flat.append(torch.from_numpy(flat))
            self.scatter.append(torch.from_numpy(sc))
            self.uses.append(torch.from_numpy(uses))
            self.pid.append(torch.from_numpy(pid))
            self.val.append(torch.from_numpy(labels[:, d].astype(np.int64)))


class FactoredQNet(nn.Module):
    """Shared encoder, value head, autoregressive mask-centred advantage heads; one scalar Q per tuple.

    Head d is a one-hidden-layer MLP of [state embedding, embeddings of components
    1..d-1]; its first layer is split into a state part (computed once per row) and
    a prefix part (computed once per distinct prefix). Every row is evaluated densely
    at the *live* prefixes only (`_plan_heads`), per distinct label, with no per-row
    index bookkeeping: the same Q and gradients as evaluating each valid tuple's
    prefixes, at close to the cost of a plain MLP. `forward_pairs` splits the
    encoder's first layer too, for the boundary rows that repeat a state per task.
    """

    def __init__(
        self,
        obs_dim: int,
        labels: np.ndarray,
        vocab_sizes: list,
        hidden: int = 256,
        embed: int = 16,
        head_hidden: int = 64,
    ):
        super().__init__()
        self.table = ActionTable(labels, vocab_sizes)
        self.dims = {
            "obs_dim": obs_dim,
            "hidden": hidden,
            "embed": embed,
            "head_hidden": head_hidden,
            "vocab_sizes": list(vocab_sizes),
        }
        n = len(vocab_sizes)
        self.head_hidden = head_hidden
        self.encoder = nn.Sequential(nn.Linear(obs_dim, hidden), nn.ReLU(), nn.Linear(hidden, hidden), nn.ReLU())
        # one matmul for the value stream's hidden layer and every head's state part
        self.from_state = nn.Linear(hidden, (n + 1) * head_hidden)
        self.value = nn.Linear(head_hidden, 1)
        # Head d's first layer on [component embeddings 1..d-1] is a sum of one learned
        # table per earlier component (a linear map of concatenated embeddings is exactly that).
        self.prefix_tables = nn.ModuleList(
            nn.ModuleList(nn.Embedding(vocab_sizes[k], head_hidden) for k in range(d)) for d in range(1, n)
        )
        for tables in self.prefix_tables:
            for t in tables:
                nn.init.normal_(t.weight, std=embed**-0.5)
        self.out = nn.ModuleList(nn.Linear(head_hidden, v) for v in vocab_sizes)
        self._plan_heads()

    AUX = ("lab_of_act", "inst_head", "out_col", "bag", "bag_off", "bag_of", "slot_act", "lab_of_slot")
    """The index tables of the dense evaluation: plain tensors, not buffers, so that the state_dict is the
    weights alone; `_apply` moves them with the weights."""

    def _apply(self, fn, recurse=True):
        """`to`, `cuda`, `cpu` and `half` carry the index tables (`AUX`, the action table) with the weights."""
        super()._apply(fn, recurse)
        for name in self.AUX:
            setattr(self, name, fn(getattr(self, name)))
        t = self.table
        for key in ("prefixes", "flat", "scatter", "uses", "pid", "val"):
            setattr(t, key, [fn(x) for x in getattr(t, key)])
        return self

    @property
    def device(self) -> torch.device:
        return self.lab_of_act.device

    def prefix_term(self, d: int) -> torch.Tensor:
        """(P_d, head_hidden): head d's first-layer input from each distinct prefix of earlier components."""
        p = self.table.prefixes[d]
        return sum(t(p[:, k]) for k, t in enumerate(self.prefix_tables[d - 1]))

    def _plan_heads(self) -> None:
        """Static tables of the dense evaluation (`q_labels`).

        Ground actions that share a factored label share their Q, so Q is computed per
        distinct label and copied to the actions. A head is evaluated only at its *live*
        prefixes, those followed by two or more values in the label table: at any other prefix
        the one value's centred advantage is A - A = 0 exactly, in value and gradient (the
        restaurant's last head has no live prefix; 10 of its 88 prefixes are live). Each live
        (head, prefix) is an *instance*; all instances go through one matmul against the live
        heads' stacked output layers, each keeps its own head's columns (padded to the widest
        head), and one 0/1 matrix sums their centred advantages onto the labels.
        """
        t, H = self.table, self.head_hidden
        labels = np.stack([v.numpy() for v in t.val], 1)
        uniq, first, lab_of_act = np.unique(labels, axis=0, return_index=True, return_inverse=True)
        L = len(uniq)
        self.lab_of_act = torch.from_numpy(lab_of_act.reshape(-1).astype(np.int64))
        self.act_by_label = np.argsort(lab_of_act.reshape(-1), kind="stable")  # actions grouped by label
        self.label_start = np.searchsorted(lab_of_act.reshape(-1)[self.act_by_label], np.arange(len(uniq)))
        inst = []  # (head, prefix id, values that follow it)
        for d in range(len(t.sizes)):
            pid, val = t.pid[d].numpy()[first], uniq[:, d]
            for p in range(t.uses[d].shape[1]):
                vals = np.unique(val[pid == p])
                if len(vals) >= 2:
                    inst.append((d, p, vals))
        heads = sorted({d for d, _, _ in inst})
        I, Vm = len(inst), max((t.sizes[d] for d in heads), default=1)
        self.n_inst, self.v_max = I, Vm
        self.inst_head = torch.tensor([d for d, _, _ in inst], dtype=torch.int64)
        self.state_width = (max(heads, default=-1) + 2) * H  # value stream and heads up to the last live
        # output rows: the live heads' weights stacked, then a zero row for the padding
        off = dict(zip(heads, np.cumsum([0] + [t.sizes[d] for d in heads])[:-1].tolist()))
        self.out_heads, pad = heads, sum(t.sizes[d] for d in heads)
        out_col = np.full((I, Vm), pad, dtype=np.int64)
        for i, (d, _, _) in enumerate(inst):
            out_col[i, : t.sizes[d]] = off[d] + np.arange(t.sizes[d])
        self.out_col = torch.from_numpy(out_col[:, None, :])  # (I, 1, V)
        # prefix part: one bag of (table, component) rows per instance, in the stacked prefix tables
        tables = [(d, k) for d in heads if d for k in range(d)]
        toff = dict(zip(tables, np.cumsum([0] + [t.sizes[k] for _, k in tables])[:-1].tolist()))
        self.prefix_mods = tuple(self.prefix_tables[d - 1][k] for d, k in tables)
        self.out_mods = tuple(self.out[d] for d in heads)
        bag, bag_off = [], []
        for d, p, _ in inst:
            bag_off.append(len(bag))
            bag += [toff[(d, k)] + int(c) for k, c in enumerate(t.prefixes[d][p].tolist())]
        self.bag, self.bag_off = torch.tensor(bag, dtype=torch.int64), torch.tensor(bag_off, dtype=torch.int64)
        self.bag_of = torch.zeros(I, sum(t.sizes[k] for _, k in tables))  # instance -> its prefix rows
        for i, (lo, hi) in enumerate(zip(bag_off, bag_off[1:] + [len(bag)])):
            self.bag_of[i, bag[lo:hi]] = 1.0
        # (instance, value) slots: which labels use them
        slot_lab = np.zeros((L, I * Vm), dtype=np.float32)
        where = {(d, p): i for i, (d, p, _) in enumerate(inst)}
        for d in heads:
            pid = t.pid[d].numpy()[first]
            for l in range(L):
                i = where.get((d, int(pid[l])))
                if i is not None:
                    slot_lab[l, i * Vm + uniq[l, d]] = 1.0
        self.slot_act = torch.from_numpy(slot_lab[lab_of_act.reshape(-1)].T.copy())  # (slots, A)
        self.lab_of_slot = torch.from_numpy(slot_lab.T.copy())  # (slots, L)

    def head_masks(self, valid: torch.Tensor) -> tuple:
        """(I, N, V) 0/1 mask of the valid values after each instance's prefix, and its (I, N, 1)
        count (at least 1): what the advantages are centred over. It depends on validity only, so
        one call serves the online and the target network (`select` takes rows of it)."""
        m = (self.slot_act @ valid.to(torch.float32).T).clamp_(max=1.0)  # (slots, N)
        m = m.view(self.n_inst, self.v_max, len(valid)).transpose(1, 2)
        return m, m.sum(-1, keepdim=True).clamp_(min=1.0)

    def mask_bits(self, valid) -> np.ndarray:
        """(N, instances * V) bool: `head_masks` of rows with this validity in a compact form, to keep
        beside the validity it depends on (`masks_from_bits` turns it back)."""
        m = self.slot_act @ torch.as_tensor(valid).to(self.device, torch.float32).T  # (slots, N)
        return (m > 0).T.cpu().numpy()

    def masks_from_bits(self, bits: np.ndarray) -> tuple:
        """`head_masks` from `mask_bits`: the same tensors, without the product over every action."""
        m = torch.from_numpy(bits.astype(np.float32)).to(self.device)
        m = m.view(len(bits), self.n_inst, self.v_max).transpose(0, 1)
        return m, m.sum(-1, keepdim=True).clamp_(min=1.0)

    def label_valid(self, valid: np.ndarray) -> np.ndarray:
        """(N, labels) bool: which factored labels have a valid ground action in each row."""
        return np.logical_or.reduceat(valid[:, self.act_by_label], self.label_start, axis=1)

    @staticmethod
    def select_masks(masks: tuple, rows: torch.Tensor) -> tuple:
        """The head masks of some rows."""
        return tuple(x.index_select(1, rows) for x in masks)

    def q_labels(self, pre: torch.Tensor, masks: tuple) -> torch.Tensor:
        """(N, labels) Q of every factored label from the first layer's pre-activations (a label
        invalid in a row gets a finite, meaningless value).

        Only the instances where some row has two or more valid values are evaluated: at a
        prefix with one valid value the centred advantage of that value is A - A = 0 exactly,
        so the others add nothing to any valid label (restaurant minibatches use 3 of 10).
        """
        H, e, w = self.head_hidden, self.encoder, self.state_width
        parts = F.linear(e[3](e[2](e[1](pre))), self.from_state.weight[:w], self.from_state.bias[:w])
        v = self.value(torch.relu(parts[:, :H]))  # (N, 1)
        N, L = parts.shape[0], self.lab_of_slot.shape[1]
        m, count = masks
        act = (count[:, :, 0] >= 2).any(1).nonzero()[:, 0]  # instances in use
        if not len(act):
            return v.expand(-1, L)
        if len(act) < self.n_inst:
            m, count = m.index_select(0, act), count.index_select(0, act)
        z = parts[:, H:].view(N, w // H - 1, H).transpose(0, 1).index_select(0, self.inst_head[act])  # (K, N, H)
        if self.prefix_mods:
            tabs = torch.cat([t.weight for t in self.prefix_mods])
            pref = F.embedding_bag(self.bag, tabs, self.bag_off, mode="sum").index_select(0, act)
            z.add_(pref[:, None])  # + the prefix parts
        w_out = torch.cat([o.weight for o in self.out_mods] + [z.new_zeros(1, H)])
        b_out = torch.cat([o.bias for o in self.out_mods] + [z.new_zeros(1)])
        adv = F.linear(z.relu_(), w_out, b_out).gather(2, self.out_col[act].expand(-1, N, -1))  # (K, N, V)
        c = adv - (adv * m).sum(-1, keepdim=True) / count  # centred over the valid values
        slots = self.lab_of_slot.view(self.n_inst, self.v_max, L).index_select(0, act).reshape(-1, L)
        return torch.addmm(v, c.transpose(0, 1).reshape(N, -1), slots)

    def forward(self, obs: torch.Tensor, valid: torch.Tensor, masks: tuple | None = None) -> torch.Tensor:
        """(N, actions) Q of every valid ground action; -inf where invalid."""
        masks = self.head_masks(valid) if masks is None else masks
        q = self.q_labels(self.encoder[0](obs), masks).index_select(1, self.lab_of_act)
        return q.masked_fill(~valid, float("-inf"))

    def q_taken(
        self, obs: torch.Tensor, valid: torch.Tensor, actions: torch.Tensor, masks: tuple | None = None
    ) -> torch.Tensor:
        """(N,) Q of each row's taken action, which is valid there (`forward` gathered, without the
        copy to every action)."""
        q = self.q_labels(self.encoder[0](obs), self.head_masks(valid) if masks is None else masks)
        return q.gather(1, self.lab_of_act[actions][:, None])[:, 0]

    def first_layer_pairs(
        self,
        bits: torch.Tensor,
        task_feat: torch.Tensor,
        state_of: torch.Tensor,
        task_of: torch.Tensor,
        objects: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """The first layer's pre-activations of the observations [bits[state_of], task_feat[task_of], and the
        pairs' goal-object features], split: its state part once per state, its task part once per task (the
        42-48 task rows of a boundary state share one state projection). `objects`: the encoding's (tasks,
        atoms, k) `object_map` where it has goal-object features (their term is the pair's own)."""
        w, b, k = self.encoder[0].weight, self.encoder[0].bias, bits.shape[1]
        n = k + task_feat.shape[1]
        bits = bits.to(w.dtype)
        pre = F.linear(bits, w[:, :k]).index_select(0, state_of) + F.linear(task_feat, w[:, k:n], b).index_select(
            0, task_of
        )
        if objects is not None:
            return pre + F.linear(object_pairs(bits, objects, state_of, task_of), w[:, n:])
        return pre

    def forward_pairs(
        self,
        bits: torch.Tensor,
        task_feat: torch.Tensor,
        state_of: torch.Tensor,
        task_of: torch.Tensor,
        valid: torch.Tensor,
        masks: tuple | None = None,
        objects: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """`forward` of the observations [bits[state_of], task_feat[task_of], ...] (`first_layer_pairs`)."""
        masks = self.head_masks(valid) if masks is None else masks
        q = self.q_labels(self.first_layer_pairs(bits, task_feat, state_of, task_of, objects), masks)
        return q.index_select(1, self.lab_of_act).masked_fill(~valid, float("-inf"))


def object_pairs(bits: torch.Tensor, objects: torch.Tensor, state_of: torch.Tensor, task_of: torch.Tensor):
    """(P, k) goal-object features (`Encoding.object_features`) of the pairs (bits[state_of], task_of): every
    distinct state's features for every task in one product, then the pairs' rows. `bits`: (..., S, atoms)
    float, its leading dimensions (seeds) kept."""
    T, A, K = objects.shape
    y = (bits @ objects.to(bits.dtype).permute(1, 0, 2).reshape(A, T * K)).unflatten(-1, (T, K))  # (..., S, T, K)
    if y.dim() == 3:
        return y[state_of, task_of]
    seeds = torch.arange(y.shape[0], device=y.device)[:, None]
    return y[seeds, state_of, task_of]


def masked_max(q: torch.Tensor, valid: torch.Tensor):
    """(max over valid actions, argmax) per row."""
    qm = q.masked_fill(~valid, float("-inf"))
    return qm.max(dim=1)


def build_network(enc: Encoding, hidden: int = 256, embed: int = 16, head_hidden: int = 64) -> FactoredQNet:
    """A fresh network for a layout's encoding."""
    return FactoredQNet(enc.obs_dim, enc.labels, [len(v) for v in enc.vocab], hidden, embed, head_hidden)
