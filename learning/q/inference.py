"""Inference engines of a trained FactoredQNet: the same Q, without torch's per-call overhead.

`LiveGreedy`   the greedy action of one row under the network's current weights (acting while training)
`NumpyQ`       every action's Q of a batch, in float64 numpy (greedy deployment, evaluation)
`BatchedQ`     max_a Q and V_AP of many int states at once, float32 numpy (the searches' values)
`NativeQ`      BatchedQ's q_max and v_ap compiled (`_qnet.c` beside this module), one state at a time
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch
from torch import nn

from learning.encoding import Encoding

from .network import FactoredQNet


class LiveGreedy:
    """The greedy action of one (state, task) under a FactoredQNet's current weights, in float32 numpy.

    Acting runs the network on one row per environment step, where torch's per-operation
    overhead is most of the cost. This reads the parameters through numpy views, so
    optimizer steps and load_state_dict (both in place) are seen without a copy, and
    evaluates `FactoredQNet.q_labels` for that row with a dozen numpy operations. Q is
    the forward's up to float32 rounding.
    """

    def __init__(self, net: FactoredQNet):
        view = lambda p: p.detach().numpy()
        e, w, H = net.encoder, net.state_width, net.head_hidden
        self.l1, self.l2 = (view(e[0].weight), view(e[0].bias)), (view(e[2].weight), view(e[2].bias))
        self.ws, self.bs = view(net.from_state.weight)[:w], view(net.from_state.bias)[:w]
        self.wv, self.bv = view(net.value.weight)[0], view(net.value.bias)
        self.tabs = [view(t.weight) for t in net.prefix_mods]
        self.outs = [(view(o.weight), view(o.bias)) for o in net.out_mods]
        self.H, self.I, self.inst_head = H, net.n_inst, net.inst_head.numpy()
        self.bag_of = net.bag_of.numpy()  # instance -> its prefix rows
        self.out_col = net.out_col[:, 0].numpy()
        self.slot_act, self.lab_of_slot = net.slot_act.numpy(), net.lab_of_slot.numpy()
        self.lab_of_act = net.lab_of_act.numpy()

    def __call__(self, obs: np.ndarray, valid: np.ndarray) -> int:
        """argmax over the valid actions of Q(obs) (obs: (obs_dim,) float32; valid: (actions,) bool)."""
        (w1, b1), (w2, b2), H = self.l1, self.l2, self.H
        h = np.maximum(w1 @ obs + b1, 0.0)
        h = np.maximum(w2 @ h + b2, 0.0)
        parts = self.ws @ h + self.bs
        q = np.full(len(self.lab_of_slot[0]), self.wv @ np.maximum(parts[:H], 0.0) + self.bv[0], dtype=np.float32)
        if self.I:
            z = parts[H:].reshape(-1, H)[self.inst_head]
            if self.tabs:
                z += self.bag_of @ np.concatenate(self.tabs)
            w_out = np.concatenate([o for o, _ in self.outs] + [np.zeros((1, H), np.float32)])
            b_out = np.concatenate([b for _, b in self.outs] + [np.zeros(1, np.float32)])
            adv = np.take_along_axis(np.maximum(z, 0.0) @ w_out.T + b_out, self.out_col, 1)  # (I, V)
            m = np.minimum(self.slot_act @ valid.astype(np.float32), 1.0).reshape(adv.shape)
            c = adv - ((adv * m).sum(1) / np.maximum(m.sum(1), 1.0))[:, None]
            q += c.reshape(-1) @ self.lab_of_slot
        qa = np.where(valid, q[self.lab_of_act], -np.inf)
        return int(qa.argmax())


class NumpyQ:
    """An inference-only copy of a network in numpy: the same Q, without torch's per-call overhead.

    Acting one state at a time (greedy deployment, evaluation) is dominated by
    the framework's overhead on tiny tensors; numpy's is several times lower.
    """

    def __init__(self, net: FactoredQNet):
        g = lambda t: t.detach().numpy().astype(np.float64)
        enc = [m for m in net.encoder if isinstance(m, nn.Linear)]
        self.layers = [(g(m.weight).T, g(m.bias)) for m in enc]
        self.state_w, self.state_b = g(net.from_state.weight).T, g(net.from_state.bias)
        self.value_w, self.value_b = g(net.value.weight).T, g(net.value.bias)
        self.out = [(g(m.weight).T, g(m.bias)) for m in net.out]
        with torch.no_grad():
            self.prefix = [None] + [g(net.prefix_term(d)) for d in range(1, len(net.table.sizes))]
        self.H, self.table = net.head_hidden, net.table
        self.pid = [t.numpy() for t in net.table.pid]
        self.val = [t.numpy() for t in net.table.val]

    def __call__(self, obs: np.ndarray, valid: np.ndarray) -> np.ndarray:
        """(N, actions) Q, -inf where invalid (as FactoredQNet.forward)."""
        h = obs.astype(np.float64)
        for w, b in self.layers:
            h = np.maximum(h @ w + b, 0.0)
        parts = h @ self.state_w + self.state_b
        H, N = self.H, len(obs)
        v = (np.maximum(parts[:, :H], 0.0) @ self.value_w + self.value_b)[:, 0]
        rows, acts = np.nonzero(valid)
        q = v[rows]
        for d in range(len(self.table.sizes)):
            P = self.table.uses[d].shape[1]
            pid, val = self.pid[d][acts], self.val[d][acts]
            flat = rows * P + pid
            used = np.zeros(N * P, dtype=bool)
            used[flat] = True
            keys = np.flatnonzero(used)
            inv = (np.cumsum(used) - 1)[flat]
            z = parts[keys // P, (d + 1) * H : (d + 2) * H]
            if d:
                z = z + self.prefix[d][keys % P]
            w, b = self.out[d]
            adv = np.maximum(z, 0.0) @ w + b
            mask = np.zeros(adv.shape)
            mask[inv, val] = 1.0
            mean = (adv * mask).sum(-1) / mask.sum(-1)
            q = q + adv[inv, val] - mean[inv]
        out = np.full(valid.shape, -np.inf)
        out[rows, acts] = q
        return out


class BatchedQ:
    """max_a Q(s, τ, a) of many int states at once: the searches' q_max and V_AP.

    The same numbers as `NumpyQ` followed by a max over the valid actions, up to
    float32 rounding. A search asks for a dozen states at a time with its own
    work in between, so a call's cost is mostly its number of numpy operations
    and the weights it reads; both are cut down:
    - the features are the atom bits plus a constant 1 (a byte -> 8 floats
      table), and one matmul with a per-task matrix gives layer 1 (the task
      part and the biases in the constant's row) together with every
      precondition variant's and task goal binding's test: a column of +1 on
      its positive atoms, -1 on its negative ones and 1 - #positive on the
      constant is 1 where the test holds and at most 0 elsewhere, so the ReLU
      of layer 1 also yields the validity masks, exactly. The constant rides
      along as a feature through the layers and carries their biases;
    - a head's centred advantage at a prefix with fewer than two valid values is
      A - A = 0, so only the *live* prefixes are evaluated, those followed by two
      or more values in the label table (10 of the restaurant's 90), each for
      every row, all heads in one matmul;
    - which (live prefix, value) slots a row's valid actions use, their masked
      means and each precondition variant's Q - V are small dense matmuls
      against fixed 0/1 tables, and the max runs over the applicable variants
      (an action's variants share its Q). A state whose task already holds has
      AUTO alone valid: its Q is V.
    Float32 throughout except the value stream, V being the largest term (up to
    240 in the two-room, where float32's step is 1.5e-5).
    """

    def __init__(self, net: FactoredQNet, enc: Encoding, chunk: int = 4096):
        """`chunk`: the most (state, task) rows valued in one pass (V_AP's pairs go in chunks)."""
        g = lambda t: t.detach().numpy().astype(np.float64)
        f = lambda a: np.ascontiguousarray(a, dtype=np.float32)
        lin = [m for m in net.encoder if isinstance(m, nn.Linear)]
        n, H, nd = enc.n_atoms, net.head_hidden, len(net.table.sizes)
        hid = lin[0].weight.shape[0]
        self.H, self.hid, self.chunk, self.enc = H, hid, chunk, enc
        self.nbytes = nb = -(-n // 8)
        self.one = 1 << (8 * nb)  # the constant feature: bit 0 of one more byte
        self.byte_bits = f(np.unpackbits(np.arange(256, dtype=np.uint8)[:, None], axis=1, bitorder="little"))
        # layer 1 and the tests: rows = atom bits (8 per byte) + the constant byte's 8 bits
        bm = enc.bm
        pos = np.concatenate([bm.pre_pos, enc.goal_pos]).astype("<u8")
        neg = np.concatenate([bm.pre_neg, enc.goal_neg]).astype("<u8")
        J, self.n_var = len(pos), len(bm.pre_pos)
        bits_of = lambda w: np.unpackbits(w.view(np.uint8).reshape(len(w), -1), axis=1, bitorder="little")[
            :, : nb * 8
        ].astype(np.float64)
        P, Nn = bits_of(pos), bits_of(neg)  # (J, atom rows)
        w1 = g(lin[0].weight).T  # (obs_dim, hidden)
        c = nb * 8  # the constant's row
        base = np.zeros((nb * 8 + 8, hid + 1 + J))
        base[:n, :hid] = w1[:n]
        base[c, :hid] = g(lin[0].bias)
        base[c, hid] = 1.0  # the constant, as a feature
        base[: nb * 8, hid + 1 :] = (P - Nn).T
        base[c, hid + 1 :] = 1.0 - P.sum(1)
        self.l1_base = f(base)
        nt = n + enc.task_feat.shape[1]
        self.task_part = enc.task_feat.astype(np.float64) @ w1[n:nt]  # (tasks, hidden)
        # goal-object features (Encoding.paired): each task's own term on the atoms' rows of layer 1
        self.object_part = np.einsum("tak,kh->tah", enc.object_map, w1[nt:]) if enc.paired else None
        self.l1_task: dict = {}  # task -> its layer-1 matrix
        self.t0, self.g0 = hid + 1, hid + 1 + self.n_var  # test columns: variants, goals
        aug = lambda w, b: np.vstack([w, b[None]])  # the constant's row: the bias
        self.w2 = f(np.hstack([aug(g(lin[1].weight).T, g(lin[1].bias)), np.eye(hid + 1)[:, -1:]]))
        ws, bs = g(net.from_state.weight).T, g(net.from_state.bias)
        const = np.zeros((hid + 1, 1))
        const[-1] = 1.0
        self.ws_v = np.hstack([aug(ws[:, :H], bs[:H]), const])  # the value stream, float64
        self.value_w = np.append(g(net.value.weight)[0], g(net.value.bias)[0])
        T = len(enc.task_feat)
        self.goal_cols = [self.g0 + np.flatnonzero(enc.goal_owner == t) for t in range(T)]
        self.goal_of = np.zeros((J - self.n_var, T), np.float32)
        self.goal_of[np.arange(J - self.n_var), enc.goal_owner] = 1.0
        # the live prefixes ("segments") and their (segment, value) columns
        tab = net.table
        labels = np.stack([v.numpy() for v in tab.val], 1)
        pids = np.stack([p.numpy() for p in tab.pid], 1)
        segs = []  # (head, prefix id, its values in the label table)
        for d in range(nd):
            for p in range(tab.uses[d].shape[1]):
                vals = np.unique(labels[pids[:, d] == p, d])
                if len(vals) >= 2:
                    segs.append((d, p, vals))
        live = sorted({d for d, _, _ in segs})
        self.n_live = len(live)
        self.segs, self.live, self._net = segs, live, net  # for the compiled engine (NativeQ)
        self.ws_h = f(
            np.hstack(
                [np.hstack([aug(ws[:, (1 + d) * H : (2 + d) * H], bs[(1 + d) * H : (2 + d) * H]), const]) for d in live]
            )
        )  # each live head's part + 1
        off = dict(zip(live, np.cumsum([0] + [tab.sizes[d] for d in live])[:-1].tolist()))
        ccat = sum(tab.sizes[d] for d in live)
        w_cat = np.zeros((H + 1, ccat))
        for d in live:
            w_cat[:, off[d] : off[d] + tab.sizes[d]] = aug(g(net.out[d].weight).T, g(net.out[d].bias))
        self.w_cat = f(w_cat)
        with torch.no_grad():
            pref = {d: g(net.prefix_term(d)) for d in live if d}
        S = len(segs)
        self.seg_head = np.array([live.index(d) for d, _, _ in segs], dtype=np.intp)
        self.seg_pref = f(
            np.hstack(
                [np.stack([pref[d][p] if d else np.zeros(H) for d, p, _ in segs]).reshape(S, H), np.zeros((S, 1))]
            )
        )
        col_sel, col_seg, col_of = [], [], {}
        for s, (d, p, vals) in enumerate(segs):
            for v in vals.tolist():
                col_of[(d, p, v)] = len(col_sel)
                col_sel.append(s * ccat + off[d] + v)
                col_seg.append(s)
        C = len(col_sel)
        self.col_sel = np.array(col_sel, dtype=np.intp)
        self.seg_of = np.zeros((C, S), np.float32)  # column -> its segment
        self.seg_of[np.arange(C), col_seg] = 1.0
        self.s_var = np.zeros((self.n_var, C), np.float32)  # variant -> its action's columns
        for j, a in enumerate(bm.op_action.tolist()):
            for d in live:
                k = col_of.get((d, int(pids[a, d]), int(labels[a, d])))
                if k is not None:
                    self.s_var[j, k] = 1.0
        seg_var = (self.s_var @ self.seg_of).T  # (segments, variants) 0/1
        self.g_adv = f(np.concatenate([self.s_var.T, -seg_var]))  # [columns | means] -> Q - V
        self.support = enc.support
        self.prob = enc.task_prob[enc.support]

    def set_distribution(self, prob) -> None:
        """V_AP's task distribution over the support from now on (default: the layout's P): a distribution
        estimator's P(τ' | the current task), `planning.world.estimators`."""
        prob = np.asarray(prob, dtype=np.float64)
        if prob.shape != self.prob.shape:
            raise ValueError(f"a distribution over the {len(self.prob)} tasks of the support, not {prob.shape}")
        self.prob = prob

    # ---- inputs ------------------------------------------------------------
    def features(self, states) -> np.ndarray:
        """(N, atom rows + 8) float32: the atom bits of int states (or of a packed uint64 array), then the constant."""
        nb = self.nbytes
        if not (isinstance(states, np.ndarray) and states.dtype == np.uint64):
            one = self.one
            try:
                raw = np.frombuffer(
                    b"".join([(s | one).to_bytes(nb + 1, "little") for s in states]), dtype=np.uint8
                ).reshape(-1, nb + 1)
                return self.byte_bits.take(raw, axis=0).reshape(len(raw), -1)
            except (TypeError, AttributeError, OverflowError):  # not Python ints: the general packing
                states = self.enc.pack(states)
        words = np.ascontiguousarray(states.reshape(-1, self.enc.n_words), dtype="<u8")
        raw = np.ones((len(words), nb + 1), np.uint8)
        raw[:, :nb] = words.view(np.uint8).reshape(len(words), -1)[:, :nb]
        return self.byte_bits.take(raw, axis=0).reshape(len(raw), -1)

    def layer1(self, task: int) -> np.ndarray:
        """A task's layer-1-and-tests matrix, its goal's bindings last (made once per task)."""
        w = self.l1_task.get(task)
        if w is None:
            w = np.concatenate([self.l1_base[:, : self.g0], self.l1_base[:, self.goal_cols[task]]], axis=1)
            w[-8, : self.hid] += self.task_part[task]
            if self.object_part is not None:
                w[: self.enc.n_atoms, : self.hid] += self.object_part[task]
            w = self.l1_task[task] = np.ascontiguousarray(w, dtype=np.float32)
        return w

    # ---- the network -------------------------------------------------------
    def values(self, h1: np.ndarray, okf: np.ndarray):
        """Per row, from layer 1 (with the constant) and the variants' 0/1 validity: the max of Q - V over the
        applicable variants (float32, -inf where none) and V (float64)."""
        N, H = len(h1), self.H
        h = h1 @ self.w2
        np.maximum(h, 0, out=h)
        pv = h.astype(np.float64) @ self.ws_v
        np.maximum(pv, 0, out=pv)
        v = pv @ self.value_w
        z = (h @ self.ws_h).reshape(N, self.n_live, H + 1).take(self.seg_head, axis=1)
        z += self.seg_pref
        np.maximum(z, 0, out=z)
        y = (z.reshape(-1, H + 1) @ self.w_cat).reshape(N, -1).take(self.col_sel, axis=1)  # advantages
        present = okf @ self.s_var
        np.minimum(present, 1.0, out=present)  # the valid (prefix, value) slots
        count = present @ self.seg_of
        np.maximum(count, 1.0, out=count)
        present *= y
        mean = present @ self.seg_of
        mean /= count
        q = np.concatenate([y, mean], axis=1) @ self.g_adv  # (N, variants) Σ centred A
        return np.maximum.reduce(q, axis=1, where=okf > 0, initial=-np.inf), v

    def q_max(self, states, task: int) -> np.ndarray:
        """max_a Q(s, task, a) per state (a task index)."""
        if len(states) == 0:
            return np.zeros(0)
        a = self.features(states) @ self.layer1(task)
        np.maximum(a, 0, out=a)
        adv, v = self.values(a[:, : self.t0], a[:, self.t0 : self.g0])
        goals = a[:, self.g0 :]
        if goals.any():
            adv[goals.any(1)] = 0.0  # AUTO alone: every head's advantage centres to 0
        return v + adv

    def v_ap(self, states) -> np.ndarray:
        """Σ_τ P(τ) max_a Q(s, τ, a) over the task support, per state."""
        if len(states) == 0:
            return np.zeros(0)
        if self.object_part is not None:  # layer 1 differs per task on the atoms' rows too: a task at a time
            return np.stack([self.q_max(states, int(t)) for t in self.support], axis=1) @ self.prob
        a = self.features(states) @ self.l1_base  # no task part yet
        hid, sup, K = self.hid, self.support, len(self.support)
        tests = np.maximum(a[:, self.t0 :], 0)
        okf = np.ascontiguousarray(tests[:, : self.n_var])
        sat = (tests[:, self.n_var :] @ self.goal_of[:, sup]) > 0  # (N, K)
        tasks = np.zeros((K, hid + 1), np.float32)
        tasks[:, :hid] = self.task_part[sup]
        out = np.empty((len(a), K))
        step = max(1, self.chunk // max(K, 1))
        for lo in range(0, len(a), step):
            hi = min(lo + step, len(a))
            h1 = np.maximum(a[lo:hi, None, : self.t0] + tasks, 0).reshape((hi - lo) * K, -1)
            adv, v = self.values(h1, np.repeat(okf[lo:hi], K, axis=0))
            adv[sat[lo:hi].reshape(-1)] = 0.0
            out[lo:hi] = (v + adv).reshape(hi - lo, K)
        return out @ self.prob


class NativeQ:
    """`BatchedQ.q_max` and `v_ap` compiled (learning/q/_qnet.c): the same function, each state valued on its own.

    A BLAS product's rounding depends on the batch (its size and a row's place
    in it), so BatchedQ's value of a state moves in its last bits (up to ~2e-5
    on the restaurant) with the states it is valued with. Here every state's
    sums run in a fixed order, so its value is a function of the state alone,
    the same in any batch and on any x86 machine (no fused multiply-adds): a
    search may value states one flush at a time, at a few microseconds each,
    with no per-call overhead. It differs from BatchedQ's by float32 rounding
    only, at most ~3e-5 on the restaurant (tests/planning/test_bn_kernel.py).
    Segments whose valid values number fewer than two add exactly 0 (A - A),
    so only the others are computed, and only the live heads they need. As a
    value is a function of its arguments, the values computed are kept (the
    memo) for the searches that follow: consecutive tasks of a sequence revisit
    many states (a fifth to a quarter of them on the restaurant).
    """

    def __init__(self, batched: "BatchedQ", lib, memo: bool = True):
        """`memo`: keep every value computed (q_max per (state, task), V_AP per state) for later calls, up to
        2**MEMO_LOG2 / 2 entries (then it starts over): exact, as a value depends on its arguments alone."""
        import ctypes

        b, enc, net = batched, batched.enc, batched._net
        model = enc.model
        g = lambda t: t.detach().numpy().astype(np.float64)
        f32 = lambda a: np.ascontiguousarray(a, dtype=np.float32)
        f64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)
        i32 = lambda a: np.ascontiguousarray(a, dtype=np.int32)
        lin = [m for m in net.encoder if isinstance(m, nn.Linear)]
        n, H, hid = enc.n_atoms, b.H, b.hid
        W = self.W = max(1, -(-n // 64))
        words = lambda masks: np.frombuffer(
            b"".join(int(m).to_bytes(8 * W, "little") for m in masks) or bytes(8 * W), dtype="<u8"
        ).copy()
        w1 = g(lin[0].weight).T
        ws, bs = g(net.from_state.weight).T, g(net.from_state.bias)
        cols = [(s, d, v) for s, (d, p, vals) in enumerate(b.segs) for v in vals.tolist()]
        var_cols = [np.flatnonzero(row).tolist() for row in b.s_var]
        groups = model.trigger_groups()  # variant -> one of its positive atoms (-1: none)
        tasks = list(model.tasks)
        goal0, goaln, gpos, gneg = [], [], [], []
        obj_t, obj_atom, obj_feat = np.nonzero(enc.object_map)  # goal-object features: per task, in atom order
        for t in tasks:
            goal0.append(len(gpos))
            goaln.append(len(t.bindings))
            gpos += [o.pos for o in t.bindings]
            gneg += [o.neg for o in t.bindings]
        self.arrays = a = {
            "w1": f32(w1[:n]),
            "b1t": f32(g(lin[0].bias)[None] + b.task_part),
            "w2": f32(g(lin[1].weight).T),
            "b2": f32(g(lin[1].bias)),
            "wv1": f32(ws[:, :H]),
            "bv1": f64(bs[:H]),
            "wv": f64(g(net.value.weight)[0]),
            "wh": f32(np.stack([ws[:, (1 + d) * H : (2 + d) * H] for d in b.live]) if b.live else np.zeros(1)),
            "bh": f32(np.stack([bs[(1 + d) * H : (2 + d) * H] for d in b.live]) if b.live else np.zeros(1)),
            "seg_head": i32(b.seg_head if len(b.segs) else np.zeros(1)),
            "seg_pref": f32(b.seg_pref[:, :H] if len(b.segs) else np.zeros(1)),
            "col_seg": i32([s for s, _, _ in cols] or [0]),
            "col_w": f32(np.stack([g(net.out[d].weight)[v] for _, d, v in cols]) if cols else np.zeros(1)),
            "col_b": f32([g(net.out[d].bias)[v] for _, d, v in cols] or [0.0]),
            "var_pos": words([o.pos for o in model.ops]),
            "var_neg": words([o.neg for o in model.ops]),
            "trig0": i32(np.cumsum([0] + [len(groups.get(i, [])) for i in range(n)])),
            "trig_var": i32(sum((list(groups.get(i, [])) for i in range(n)), []) or [0]),
            "always": i32(groups.get(-1, []) or [0]),
            "var_col0": i32(np.cumsum([0] + [len(c) for c in var_cols])[:-1]),
            "var_coln": i32([len(c) for c in var_cols]),
            "var_cols": i32(sum(var_cols, []) or [0]),
            "goal0": i32(goal0),
            "goaln": i32(goaln),
            "goal_pos": words(gpos),
            "goal_neg": words(gneg),
            "obj0": i32(np.searchsorted(obj_t, np.arange(len(tasks) + 1))),
            "obj_atom": i32(obj_atom if len(obj_atom) else [0]),
            "obj_feat": i32(obj_feat if len(obj_feat) else [0]),
            "wobj": f32(w1[n + enc.task_feat.shape[1] :] if enc.paired else np.zeros(1)),
        }
        P, I = ctypes.c_void_p, ctypes.c_int64

        class Spec(ctypes.Structure):
            _fields_ = (
                [(k, I) for k in ("W", "n_atoms", "hid", "H", "n_live", "n_seg", "n_col", "n_var", "n_tasks")]
                + [(k, P) for k in ("w1", "b1t", "w2", "b2", "wv1", "bv1", "wv")]
                + [("bv", ctypes.c_double)]
                + [
                    (k, P)
                    for k in (
                        "wh",
                        "bh",
                        "seg_head",
                        "seg_pref",
                        "col_seg",
                        "col_w",
                        "col_b",
                        "var_pos",
                        "var_neg",
                        "trig0",
                        "trig_var",
                        "always",
                    )
                ]
                + [("n_always", I)]
                + [
                    (k, P)
                    for k in ("var_col0", "var_coln", "var_cols", "goal0", "goaln", "goal_pos", "goal_neg", "memo")
                ]
                + [(k, P) for k in ("obj0", "obj_atom", "obj_feat", "wobj")]
            )

        self.spec = Spec(
            W=W,
            n_atoms=n,
            hid=hid,
            H=H,
            n_live=len(b.live),
            n_seg=len(b.segs),
            n_col=len(cols),
            n_var=len(model.ops),
            n_tasks=len(tasks),
            bv=float(g(net.value.bias)[0]),
            n_always=len(groups.get(-1, [])),
            **{k: v.ctypes.data for k, v in a.items()},
        )
        self.lib, self.ctx, self.model = lib, ctypes.addressof(self.spec), model
        self.spec.memo = self._memo = lib.qnet_memo_new(W, MEMO_LOG2) if memo else None
        self.fn = ctypes.cast(lib.qnet_q_max, ctypes.c_void_p).value  # the search's bn_native_fn
        self.support = i32(enc.support)
        self.prob = f64(enc.task_prob[enc.support])
        self.key, self._keys = -1, {self.prob.tobytes(): -1}  # the memo's name of each distribution used

    def set_distribution(self, prob) -> None:
        """V_AP's task distribution over the support from now on (`BatchedQ.set_distribution`); the memo keeps
        each distribution's values apart."""
        self.prob = np.ascontiguousarray(prob, dtype=np.float64)
        self.key = self._keys.setdefault(self.prob.tobytes(), -1 - len(self._keys))

    def __del__(self):
        if getattr(self, "_memo", None):
            self.lib.qnet_memo_free(self._memo)
            self._memo = None

    def memo_stats(self) -> dict:
        """Entries held, hits and misses of the memo so far."""
        import ctypes

        out = (ctypes.c_int64 * 3)()
        self.lib.qnet_memo_stats(self._memo, out)
        return {"entries": out[0], "hits": out[1], "misses": out[2]}

    def words(self, states) -> np.ndarray:
        W = self.W
        return np.frombuffer(b"".join(s.to_bytes(8 * W, "little") for s in states) or bytes(8 * W), dtype="<u8")

    def q_max(self, states, task: int) -> np.ndarray:
        """max_a Q(s, task, a) per int state (a task index)."""
        out, words = np.zeros(len(states)), self.words(states)  # kept alive through the call
        if len(states) and self.lib.qnet_q_max(
            self.ctx, int(task), words.ctypes.data, len(states), self.W, out.ctypes.data
        ):
            raise MemoryError("qnet_q_max failed")
        return out

    def v_ap(self, states) -> np.ndarray:
        """Σ_τ P(τ) max_a Q(s, τ, a) over the task support, per int state."""
        out, words = np.zeros(len(states)), self.words(states)
        if len(states) and self.lib.qnet_v_ap(
            self.ctx,
            words.ctypes.data,
            len(states),
            self.W,
            self.support.ctypes.data,
            self.prob.ctypes.data,
            len(self.support),
            self.key,
            out.ctypes.data,
        ):
            raise MemoryError("qnet_v_ap failed")
        return out


_QNET_LIB = None
MEMO_LOG2 = 20  # the memo's slots (32 bytes each in the restaurant): 2**20, half of them used at most


def _qnet_lib():
    """The compiled learning/q/_qnet.c (planning.native), or None (no compiler, or QNET_NATIVE=0)."""
    global _QNET_LIB
    if _QNET_LIB is None:
        import ctypes

        from planning import native

        so = native.load(Path(__file__).with_name("_qnet.c"), "QNET_NATIVE")
        if so is not None:
            P, I = ctypes.c_void_p, ctypes.c_int64
            so.qnet_q_max.restype = ctypes.c_int
            so.qnet_q_max.argtypes = [P, I, P, I, I, P]
            so.qnet_v_ap.restype = ctypes.c_int
            so.qnet_v_ap.argtypes = [P, P, I, I, P, P, I, I, P]
            so.qnet_memo_new.restype = P
            so.qnet_memo_new.argtypes = [I, I]
            so.qnet_memo_free.argtypes = [P]
            so.qnet_memo_stats.argtypes = [P, P]
        _QNET_LIB = so or False
    return _QNET_LIB or None
