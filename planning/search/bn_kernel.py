"""The Bellman–Novelty loop compiled (planning/search/_bn.c): its binding, the model index it reads, one search.

For a compiled model (`planning.domain.model.Model` without derived
predicates, at most 4,096 atoms, integer costs) and a task with goal bindings
the loop of `planning.search.bellman_novelty` runs in C, built on first use
with the system C compiler (`planning.native`; `ANTICIPATORY_BN_NATIVE=0`:
never). `Kernel` is the model's successor index as arrays: its successors
are Model.successors' in the same order, checked against them on probe states
before a model's kernel is used (`kernel_for`). The C loop's heaps, counters,
dedup tables, width cache and value batches are the Python loop's, so with the
same value it makes the same choices bit for bit.

`CompiledSearch` is one search. A value that offers a compiled q_max
(`value.native_q_max(task)` -> an object with `fn`, a `bn_native_fn` of
_bn.c, `ctx`, optionally `v_ap` and the `model` it was compiled for; the
Q-network's, `learning.q.inference.NativeQ`) is called from C at each flush with
exactly the states the flush needs (no prefetch: a compiled value's result
for a state does not depend on the batch, and its per-call cost is nil), and
its `v_ap` scores the terminals; any other value is called back in Python
with the batches of the Python loop (`run` resumes the loop after each).
"""

from __future__ import annotations

import ctypes
import time
import weakref
from numbers import Integral
from pathlib import Path
from typing import Self

import numpy as np

from planning import native
from planning.search.bn_stats import BNStats
from planning.search.terminals import Terminal

NATIVE_PREFETCH = 0  # most states per q_max call with a compiled value: none (each valued when needed)
TRACE_KINDS = ("bellman", "novelty", "forfeit", "stale")  # _bn.c's trace codes


_P = ctypes.c_void_p
_I64 = ctypes.c_int64


class _ModelSpec(ctypes.Structure):
    """bn_model of _bn.c: the successor index as arrays, and the current task's goal."""

    _fields_ = [
        ("W", _I64),
        ("n_atoms", _I64),
        ("n_actions", _I64),
        ("n_entries", _I64),
        ("e_pos", _P),
        ("e_neg", _P),
        ("e_add", _P),
        ("e_del", _P),
        ("e_action", _P),
        ("e_cost", _P),
        ("e_multi", _P),
        ("e_cond0", _P),
        ("e_condn", _P),
        ("c_pos", _P),
        ("c_neg", _P),
        ("c_add", _P),
        ("c_del", _P),
        ("n_always", _I64),
        ("trig0", _P),
        ("n_goals", _I64),
        ("g_pos", _P),
        ("g_neg", _P),
    ]


class _Stats(ctypes.Structure):
    _fields_ = [
        (k, _I64)
        for k in (
            "expansions",
            "bellman",
            "novelty",
            "forfeited",
            "stale",
            "skipped",
            "dropped",
            "repushed",
            "generated",
            "nodes",
            "terminals",
            "value_calls",
            "value_states",
            "states",
            "trace",
        )
    ] + [(k, ctypes.c_double) for k in ("t_sim", "t_nov", "t_val")]


_LIB = None
_MODELS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
MAX_WORDS = 64  # _bn.c's limit: 4,096 atoms


def lib():
    """The compiled loop, or None (no compiler, or ANTICIPATORY_BN_NATIVE=0)."""
    global _LIB
    if _LIB is None:
        so = native.load(Path(__file__).with_name("_bn.c"), "ANTICIPATORY_BN_NATIVE")
        if so is not None:
            P, I64, D = _P, _I64, ctypes.c_double
            so.bn_new.restype = P
            so.bn_new.argtypes = [P, I64, I64, P, D, I64, I64, ctypes.c_int, ctypes.c_int]
            so.bn_set_native.argtypes = [P, P, P]
            so.bn_free.argtypes = [P]
            so.bn_start.restype = ctypes.c_int
            so.bn_start.argtypes = [P, P, ctypes.c_int, P, I64, D, I64]
            so.bn_run.restype = ctypes.c_int
            so.bn_run.argtypes = [P]
            so.bn_get_stats.argtypes = [P, P]
            so.bn_need.restype = I64
            so.bn_need.argtypes = [P, ctypes.POINTER(P), ctypes.POINTER(P)]
            so.bn_add_value_time.argtypes = [P, D]
            so.bn_get_terminals.argtypes = [P, P, P, P, P, P, P]
            so.bn_plan.restype = I64
            so.bn_plan.argtypes = [P, ctypes.c_int32, P, I64]
            so.bn_get_trace.argtypes = [P, P, P, P]
            so.bn_successors.restype = I64
            so.bn_successors.argtypes = [P, P, P, P, P, P, I64]
        _LIB = so or False
    return _LIB or None


def _ptr(a: np.ndarray) -> int:
    return a.ctypes.data


class Kernel:
    """A compiled model's successor index for _bn.c (arrays kept alive here), and the goals of its tasks."""

    def __init__(self, model):
        W = self.W = max(1, -(-len(model.atoms) // 64))
        self.n_atoms, self.n_actions = len(model.atoms), len(model.actions)
        words = lambda masks: (
            np.frombuffer(b"".join(m.to_bytes(8 * W, "little") for m in masks) or b"", dtype="<u8").copy()
            if masks
            else np.zeros(W, "<u8")
        )
        groups = model.trigger_groups()
        order = list(groups.get(-1, []))
        trig0 = [0] * (self.n_atoms + 1)
        for i in range(self.n_atoms):
            trig0[i] = len(order)
            order += groups.get(i, [])
        trig0[self.n_atoms] = len(order)
        counts: dict = {}
        for a in model.op_action:
            counts[a] = counts.get(a, 0) + 1
        ops = [model.ops[v] for v in order]
        acts = [model.op_action[v] for v in order]
        conds, cond0, condn = [], [], []
        for op in ops:
            cond0.append(len(conds))
            condn.append(len(op.cond))
            conds += list(op.cond)
        a = self.arrays = {
            "e_pos": words([o.pos for o in ops]),
            "e_neg": words([o.neg for o in ops]),
            "e_add": words([o.add for o in ops]),
            "e_del": words([o.dele for o in ops]),
            "e_action": np.array(acts, np.int32),
            "e_cost": np.array([model.action_cost[x] for x in acts], np.int64),
            "e_multi": np.array([counts[x] > 1 for x in acts], np.uint8),
            "e_cond0": np.array(cond0, np.int32),
            "e_condn": np.array(condn, np.int32),
            "c_pos": words([c[0] for c in conds]),
            "c_neg": words([c[1] for c in conds]),
            "c_add": words([c[2] for c in conds]),
            "c_del": words([c[3] for c in conds]),
            "trig0": np.array(trig0, np.int32),
        }
        if not len(a["e_action"]):
            a["e_action"], a["e_cost"] = np.zeros(1, np.int32), np.zeros(1, np.int64)
            a["e_multi"], a["e_cond0"], a["e_condn"] = (
                np.zeros(1, np.uint8),
                np.zeros(1, np.int32),
                np.zeros(1, np.int32),
            )
        self.spec = _ModelSpec(
            W=W,
            n_atoms=self.n_atoms,
            n_actions=self.n_actions,
            n_entries=len(ops),
            n_always=len(groups.get(-1, [])),
            **{k: _ptr(v) for k, v in a.items()},
        )
        self.goals: dict = {}

    def words(self, states) -> np.ndarray:
        W = self.W
        return np.frombuffer(b"".join(s.to_bytes(8 * W, "little") for s in states), dtype="<u8").copy()

    def ints(self, words: np.ndarray, n: int) -> list:
        raw, k = words.tobytes(), 8 * self.W
        return [int.from_bytes(raw[i * k : (i + 1) * k], "little") for i in range(n)]

    def with_goal(self, task) -> _ModelSpec:
        """The spec with this task's goal (any binding's (pos, neg) holds)."""
        g = self.goals.get(task.index)
        if g is None:
            g = self.goals[task.index] = (
                self.words([b.pos for b in task.bindings]),
                self.words([b.neg for b in task.bindings]),
                len(task.bindings),
            )
        spec = _ModelSpec.from_buffer_copy(self.spec)
        spec.g_pos, spec.g_neg, spec.n_goals = _ptr(g[0]), _ptr(g[1]), g[2]
        return spec

    def successors(self, so, state: int, task) -> list:
        """[(action, next state, cost, completes τ)] of a state as the compiled loop (`so`: `lib()`) computes them."""
        spec = self.with_goal(task)
        one = np.ones(1)
        h = so.bn_new(ctypes.addressof(spec), 0, 0, _ptr(one), 1.0, 0, 0, 0, 0)
        try:
            cap = self.n_actions + 1
            act, cost = np.zeros(cap, np.int32), np.zeros(cap, np.int64)
            nxt, hit = np.zeros(cap * self.W, "<u8"), np.zeros(cap, np.uint8)
            s = self.words([state])  # kept alive through the call
            n = so.bn_successors(h, _ptr(s), _ptr(act), _ptr(cost), _ptr(nxt), _ptr(hit), cap)
            return list(zip(act[:n].tolist(), self.ints(nxt, n), cost[:n].tolist(), hit[:n].astype(bool).tolist()))
        finally:
            so.bn_free(h)


def kernel_for(model, task, state: int):
    """The compiled model for this search, or None where the C loop does not apply."""
    so = lib()
    if so is None or not getattr(task, "bindings", None) or not hasattr(task, "index"):
        return None
    k = _MODELS.get(model) if _weakrefable(model) else None
    if k is None:
        k = _build_kernel(so, model, task, state)
        if k is None:
            return None
        if _weakrefable(model):
            _MODELS[model] = k
    if k is False or state.bit_length() > 64 * k.W:
        return None
    return k


def _weakrefable(model) -> bool:
    try:
        weakref.ref(model)
        return True
    except TypeError:
        return False


def _build_kernel(so, model, task, state: int):
    """A Kernel for a compiled model whose successors it reproduces exactly, else False (None: not a model)."""
    from planning.domain.model import Model

    if not isinstance(model, Model) or type(model).successors is not Model.successors or "successors" in vars(model):
        return None
    if (
        getattr(model, "axioms", None) is not None
        or len(model.atoms) > 64 * MAX_WORDS
        or not all(isinstance(c, Integral) for c in model.action_cost)
    ):
        return False
    try:
        k = Kernel(model)
        probes = [model.init, state] + model.random_walk_states(24, 0, walk=12)
    except Exception:  # noqa: BLE001 - anything unexpected: the Python loop
        return False
    for s in probes:  # the compiled successors must be Model.successors, in order
        want = [(a, t, c, bool(task.satisfied(t))) for a, t, c in model.successors(s)]
        if k.successors(so, s, task) != want:
            return False
    return k


class CompiledSearch:
    """One search of the compiled loop: a _bn.c handle (freed by `close`, or on leaving a `with` block)."""

    def __init__(
        self,
        kernel: Kernel,
        model,
        task,
        value,
        *,
        budget: int,
        depth_cap: int,
        gamma: float,
        scale: float,
        prefetch: int,
        native_value: bool,
        tracing: bool,
    ):
        """native_value: let C call the value's compiled q_max where it has one for this model."""
        self.lib, self.kernel = lib(), kernel
        self.value, self.task, self.depth_cap = value, task, depth_cap
        fast = None
        if native_value and callable(getattr(value, "native_q_max", None)):
            fast = value.native_q_max(task)  # None where the value has no compiled form here
            if fast is not None and getattr(fast, "model", model) is not model:
                fast = None  # compiled for another model: the value's own q_max
        self.fast = fast
        self.v_ap = getattr(fast, "v_ap", None) or value.v_ap  # the compiled value's V_AP with its q_max
        self.gpow = np.array([gamma**d for d in range(max(depth_cap, 0) + 1)], dtype=np.float64)
        self.spec = kernel.with_goal(task)
        self.h = self.lib.bn_new(
            ctypes.addressof(self.spec),
            int(budget),
            int(depth_cap),
            _ptr(self.gpow),
            float(scale),
            int(prefetch) if fast is None else NATIVE_PREFETCH,
            int(task.index),
            1,
            int(tracing),
        )
        if not self.h:
            raise MemoryError("the compiled Bellman–Novelty search could not allocate its tables")
        if fast is not None:
            self.lib.bn_set_native(self.h, fast.fn, fast.ctx)
        self.terminals: list = []  # Terminal, in discovery order
        self.terminal_node: list = []  # per terminal: the node it was reached from (-1: none)
        self.terminal_action: list = []  # per terminal: the action from that node (None: none)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        if self.h:
            self.lib.bn_free(self.h)
            self.h = None

    def run(self, state: int, reference: Terminal | None, stats: BNStats, trace: list | None) -> None:
        """Algorithms 3-4 from `state`, the reference terminal (if any) admitted first; fills the terminals,
        the stats' counts and times, and the trace (if a list)."""
        so, h, k = self.lib, self.h, self.kernel
        root = k.words([state])
        rs = k.words([reference.state]) if reference is not None else root
        if (
            so.bn_start(
                h,
                _ptr(root),
                int(reference is not None),
                _ptr(rs),
                reference.depth if reference else 0,
                reference.G if reference else 0.0,
                reference.cost if reference else 0,
            )
            < 0
        ):
            raise MemoryError("the compiled Bellman–Novelty search ran out of memory")
        rc = so.bn_run(h)
        ps, pq = _P(), _P()
        while rc == 1:  # a Python value: value the flush's states, resume
            n = so.bn_need(h, ctypes.byref(ps), ctypes.byref(pq))
            need = k.ints(np.ctypeslib.as_array(ctypes.cast(ps, ctypes.POINTER(ctypes.c_uint64)), (n * k.W,)), n)
            t0 = time.perf_counter()
            q = np.asarray(self.value.q_max(need, self.task), dtype=np.float64)
            so.bn_add_value_time(h, time.perf_counter() - t0)
            np.ctypeslib.as_array(ctypes.cast(pq, ctypes.POINTER(ctypes.c_double)), (n,))[:] = q
            rc = so.bn_run(h)
        if rc == -2:
            raise ValueError("the value's compiled q_max refused the search's states or task (another model?)")
        if rc < 0:
            raise MemoryError("the compiled Bellman–Novelty search ran out of memory (or past 2^32 pushes)")
        st = _Stats()
        so.bn_get_stats(h, ctypes.byref(st))
        self._read_terminals(st.terminals, reference is not None)
        if trace is not None and st.trace:
            n = st.trace
            kinds, tr_s, tr_d = np.zeros(n, np.int8), np.zeros(n * k.W, "<u8"), np.zeros(n, np.int32)
            so.bn_get_trace(h, _ptr(kinds), _ptr(tr_s), _ptr(tr_d))
            for kind, s, d in zip(kinds.tolist(), k.ints(tr_s, n), tr_d.tolist()):
                trace.append((TRACE_KINDS[kind],) if kind == 2 else (TRACE_KINDS[kind], s, d))
        stats.expansions, stats.bellman_expansions, stats.novelty_expansions = st.expansions, st.bellman, st.novelty
        stats.forfeited, stats.stale, stats.novelty_skipped = st.forfeited, st.stale, st.skipped
        stats.novelty_dropped, stats.novelty_repushed = st.dropped, st.repushed
        stats.generated, stats.nodes = st.generated, st.nodes
        stats.value_seconds, stats.value_calls, stats.value_states = st.t_val, st.value_calls, st.value_states
        stats.simulator_seconds += st.t_sim
        stats.novelty_seconds = st.t_nov

    def _read_terminals(self, nt: int, has_reference: bool) -> None:
        k, m = self.kernel, max(nt, 1)
        t_states, t_depth, t_G = np.zeros(m * k.W, "<u8"), np.zeros(m, np.int32), np.zeros(m)
        t_cost, t_parent, t_action = np.zeros(m, np.int64), np.zeros(m, np.int32), np.zeros(m, np.int32)
        self.lib.bn_get_terminals(
            self.h, _ptr(t_states), _ptr(t_depth), _ptr(t_G), _ptr(t_cost), _ptr(t_parent), _ptr(t_action)
        )
        for i, (s, d, G, c, par, act) in enumerate(
            zip(
                k.ints(t_states, nt),
                t_depth[:nt].tolist(),
                t_G[:nt].tolist(),
                t_cost[:nt].tolist(),
                t_parent[:nt].tolist(),
                t_action[:nt].tolist(),
            )
        ):
            reference = i == 0 and has_reference
            self.terminals.append(Terminal("reference" if reference else "search", c, d, G, s))
            self.terminal_node.append(-1 if reference or par < 0 else par)
            self.terminal_action.append(None if reference or par < 0 else act)

    def plan(self, i: int) -> list:
        """The actions of search terminal i: the path to the node it was reached from, then its action."""
        node = self.terminal_node[i]
        if node < 0:
            return []  # the root completes τ
        buf = np.zeros(max(self.depth_cap, 1) + 1, np.int32)
        n = self.lib.bn_plan(self.h, node, _ptr(buf), len(buf))
        return buf[:n][::-1].tolist() + [self.terminal_action[i]]
