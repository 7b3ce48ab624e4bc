"""Bellman–Novelty search (thesis §4.2, Appendix A.3, Algorithms 3 and 4), generic over a value.

One node set, two frontiers. The Bellman heap H_B follows the value toward
completing the current task τ: max-first on G + γ^d q_max(s, τ), FIFO on ties.
The novelty heap H_N is value-free: min-first on (width, depth, counter), the
width taken against atom and pair tables that grow only when a node is
expanded on a novelty turn. Turns go Bellman, Bellman, Bellman, novelty. A
completing successor is a candidate terminal; when the expansion budget is
spent (or both heaps are empty) the terminal with the highest preparedness
V_AP of its post-consumption state is chosen among those whose cost is within
β times the myopic reference cost C_myo (Eq. 4.1).

Bookkeeping (Algorithms 3-4, followed line by line):
- a node is (state, parent, action, depth d, discounted prefix return G, cost c);
  a step from depth d with PDDL cost k gives G' = G − γ^d k / scale, c' = c + k,
  so G is in RL units (domain.toml [reward] cost_scale) and c in PDDL units;
- `seen` maps (state, depth) to the best G admitted, checked before a push and
  again before a terminal is admitted; `expanded` is the expansion ledger;
- the depth cap gates open nodes only; terminals are not capped;
- an empty Bellman heap forfeits its turn (no fall-through to the novelty heap);
  a stale Bellman pop (already expanded with G at least as high, or at the cap)
  forfeits its turn too; neither is charged to the budget;
- a novelty turn pops until it finds work: it skips stale nodes, recomputes the
  width, drops a node no longer novel, re-pushes one whose width got worse;
- only real expansions count toward the budget.

The myopic reference plan (from a classical planner, supplied by the caller)
is replayed from s0 and cut where τ first holds; that terminal is admitted
first and its cost is C_myo. Without one, C_myo is the cheapest search
terminal. With β ≥ 1 the reference is always eligible.

The thesis's settings (§5.2.4, Table A.3): depth cap 20; budget 5,000
expansions two-room and 20,000 three-room (the authors' runs); β = 1.25
two-room and 3.0 three-room. The caller passes them.

Equivalences used for speed; none changes what is expanded or chosen (up to
the rounding of a batched value, which may depend on the batch):
- children are valued in batches and their Bellman keys pushed just before the
  next Bellman pop, each with the counter it got when enqueued, so H_B is the
  same at every pop as with eager valuation; a novelty expansion's children
  share a value call with the Bellman expansion's before it;
- q_max is cached per state within a search (a state recurs at many depths),
  and so are its successors with their goal tests and its width (per version
  of the tables; a state found not novel stays so, the tables only grow);
- a flush that has to call the value also values, in the same call and up to
  `prefetch` states in all, the non-completing successors of the states it
  values: the likeliest next pushes. It values some states never pushed, and
  saves most of the per-call overhead of a network value (`prefetch=0`: off);
- V_AP only matters to selection, so it is computed at the end, in one batched
  call, for the terminals eligible under β·C_myo only (the others are never chosen);
- a child of a novelty-expanded node has its width checked on the pairs that
  involve the atoms its action added (`NoveltyTables.width`'s exact fast path).

Two implementations of the loop, the same turn for turn. For a compiled model
(`planning.domain.model.Model` without derived predicates) and a task with goal
bindings the loop runs in C (`_bn.c`, built on first use with the system C
compiler like the LM-cut kernel, `planning.search.native`): its successors
are Model.successors' in the same order (checked against it on each model's
first search), and its heaps, counters, dedup tables, width cache and value
batches are the Python loop's, so with the same value it makes the same
choices bit for bit (tests/planning/test_bn_kernel.py). A value that offers
a compiled q_max (`value.native_q_max(task)` -> an object with `fn`, a
`bn_native_fn` of _bn.c, `ctx`, optionally `v_ap` and the `model` it was
compiled for; the Q-network's, `learning.qnet.NativeQ`) is called from C
at each flush with exactly the states the flush needs (no prefetch: a
compiled value's result for a state does not depend on the batch, and its
per-call cost is nil), and its `v_ap` scores the terminals; any other value
is called back in Python with the batches above. Elsewhere, or with `ANTICIPATORY_BN_NATIVE=0` or no C
compiler, the Python loop below runs. `kernel=` ("auto", "c", "python") and
`native_value=` force a path. The loop before the kernel is kept verbatim in
`planning.search.bellman_novelty_reference` (the benchmark's reference).
Measured with `learning.bench_bn`: results/bench-bn-*.json.
"""
from __future__ import annotations

import ctypes
import heapq
import itertools
import time
import weakref
from dataclasses import dataclass, field
from numbers import Integral
from pathlib import Path
from typing import NamedTuple

import numpy as np

from planning.search import native
from planning.search.novelty import NoveltyTables

BELLMAN_TURNS = 3                 # Bellman turns per novelty turn (Algorithm 3, lines 6-16)
DEPTH_CAP = 20                    # d_max of Table A.3
PREFETCH = 64                     # most states per q_max call when a flush speculatively values grandchildren
NATIVE_PREFETCH = 0               # the same with a compiled value: none (each state valued when needed)
INF = float("inf")


class Terminal(NamedTuple):
    """A candidate completion of the current task, in discovery order."""

    source: str                   # "reference" (the myopic plan) or "search"
    cost: float                   # undiscounted PDDL cost of the prefix
    depth: int
    G: float                      # discounted prefix return (RL units, ≤ 0)
    state: int                    # the completing state, before consumption
    v_ap: float | None = None     # V_AP of the post-consumption state; None if not scored (ineligible)


@dataclass
class BNStats:
    """What a search did and chose; times in seconds."""

    c_myo: float | None = None          # the cost bound's reference
    terminals: int = 0                  # candidate terminals admitted (the reference included)
    eligible: int = 0                   # of which within β·C_myo
    expansions: int = 0                 # charged to the budget
    bellman_expansions: int = 0
    novelty_expansions: int = 0
    forfeited: int = 0                  # Bellman turns lost to an empty heap
    stale: int = 0                      # Bellman turns lost to a stale pop
    novelty_skipped: int = 0            # stale novelty pops (the turn went on popping)
    novelty_dropped: int = 0            # no longer novel at pop
    novelty_repushed: int = 0           # width got worse at pop
    generated: int = 0                  # successors generated
    nodes: int = 0                      # open nodes admitted
    source: str | None = None           # of the chosen terminal
    v_ap: float | None = None           # of the chosen terminal
    cost: float | None = None
    depth: int | None = None
    seconds: float = 0.0
    value_seconds: float = 0.0          # q_max and V_AP calls
    value_calls: int = 0
    value_states: int = 0               # states valued (after the per-state caches)
    simulator_seconds: float = 0.0      # successors, goal tests, consumption, reference replay
    novelty_seconds: float = 0.0        # width tests and registration


@dataclass
class BNResult:
    plan: list | None                   # ground action indices of the chosen terminal; None: no selection
    stats: BNStats
    terminals: list = field(default_factory=list)   # every Terminal, in discovery order


def select_terminal(terminals: list, c_myo: float | None, beta: float) -> int | None:
    """Eq. 4.1: the index of the terminal with the highest V_AP among those with cost ≤ β·C_myo.

    Ties go to the lower cost, then the smaller depth, then the earlier
    discovery (list order). None if there is no terminal or none is eligible.
    """
    if not terminals or c_myo is None:
        return None
    bound = beta * c_myo
    best, best_key = None, None
    for i, t in enumerate(terminals):
        if not _within(t.cost, bound):
            continue
        key = (-t.v_ap, t.cost, t.depth, i)
        if best_key is None or key < best_key:
            best, best_key = i, key
    return best


def _within(cost: float, bound: float) -> bool:
    return cost <= bound + 1e-9 * max(1.0, abs(bound))   # β·C in floats: 1.25 * 4 must admit 5


def _goal_test(task):
    """A fast `task.satisfied`: the goal's (pos, neg) masks inlined where the task exposes them."""
    bindings = getattr(task, "bindings", None)
    if not bindings:
        return task.satisfied
    goals = tuple((b.pos, b.neg) for b in bindings)
    if len(goals) == 1:
        (pos, neg), = goals
        return lambda s: s & pos == pos and not s & neg
    return lambda s: any(s & p == p and not s & n for p, n in goals)


def bellman_novelty_search(model, state: int, task, value, *, budget: int, beta: float,
                           depth_cap: int = DEPTH_CAP, reference_plan: list | None = None,
                           gamma: float | None = None, scale: float | None = None,
                           trace: list | None = None, prefetch: int = PREFETCH, kernel: str = "auto",
                           native_value: bool = True) -> BNResult:
    """Algorithms 3-4: the plan of the most-prepared terminal of `task` from `state` within β·C_myo.

    model: anything with `successors(state) -> [(action, next_state, cost)]`,
    and `apply` and `action_cost` when a reference plan is given. value: the
    value protocol (`planning.value`). budget: expansions; depth_cap: d_max on
    open nodes; beta: the cost slack (≥ 1); reference_plan: the myopic plan
    (ground action indices) or None. gamma defaults to `value.gamma`, scale to
    the model's [reward] cost_scale. trace, if a list, receives one entry per
    turn: ("bellman"|"novelty", state, depth) per expansion, ("forfeit",) or
    ("stale", state, depth) for a lost Bellman turn. prefetch: the most states
    a value call takes when it speculatively values grandchildren (0: off).
    kernel: "auto" (the C loop where it applies, else Python), "c" (an error
    where it does not) or "python"; native_value: call a compiled q_max of the
    value where it has one (False: the value's Python q_max, with the batches
    of the Python loop).
    """
    if gamma is None:
        gamma = getattr(value, "gamma", None)
        if gamma is None:
            raise ValueError("the value has no gamma; pass gamma= to the search")
    if scale is None:
        scale = float(getattr(model, "cost_scale", 1))      # a stand-in model without one: PDDL units
    if beta < 1:
        raise ValueError(f"beta must be at least 1 (got {beta}): the reference must stay eligible")
    if kernel not in ("auto", "c", "python"):
        raise ValueError(f"kernel must be 'auto', 'c' or 'python', not {kernel!r}")
    if kernel != "python":
        k = _kernel_for(model, task, state)
        if k is not None:
            return _search_c(k, model, state, task, value, budget=budget, beta=beta, depth_cap=depth_cap,
                             reference_plan=reference_plan, gamma=gamma, scale=scale, trace=trace,
                             prefetch=prefetch, native_value=native_value)
        if kernel == "c":
            raise RuntimeError("the compiled search does not apply here (no C compiler, "
                               "ANTICIPATORY_BN_NATIVE=0, or not a compiled model and task)")
    return _search_python(model, state, task, value, budget=budget, beta=beta, depth_cap=depth_cap,
                          reference_plan=reference_plan, gamma=gamma, scale=scale, trace=trace, prefetch=prefetch)


def _search_python(model, state: int, task, value, *, budget: int, beta: float, depth_cap: int,
                   reference_plan: list | None, gamma: float, scale: float, trace: list | None,
                   prefetch: int) -> BNResult:
    """The loop in Python (Algorithms 3-4), for any model and value."""
    t_start = time.perf_counter()
    clock = time.perf_counter
    stats = BNStats()
    goal = _goal_test(task)
    successors = model.successors
    tables = NoveltyTables(_n_atoms(model, state))
    width, register = tables.width, tables.register
    heappush, heappop = heapq.heappush, heapq.heappop
    tick = itertools.count()          # NEXT: push order, the FIFO tie-break of both heaps

    # Nodes as parallel lists indexed by node id (no object per node).
    n_state, n_parent, n_action, n_depth, n_G, n_cost = [], [], [], [], [], []
    seen = [{} for _ in range(max(depth_cap, 0) + 1)]        # per depth: state -> best G admitted
    expanded = [{} for _ in range(max(depth_cap, 0) + 1)]    # per depth: state -> G when expanded
    gpow = [gamma ** k for k in range(max(depth_cap, 0) + 1)]
    terminals: list = []              # (state, depth, G, cost, parent, action, source, plan)
    h_bellman, h_novelty = [], []
    pending: list = []                # (node, counter) enqueued but not yet valued and pushed on H_B
    q_cache: dict = {}                # state -> q_max(state, τ)
    succ_cache: dict = {}             # state -> its expansion_of list
    w_cache: dict = {}                # state -> (tables version, width)
    t_sim = t_nov = t_val = 0.0
    value_calls = value_states = 0

    def admit_terminal(s, d, G, c, parent, action, source, plan=None):   # TRYADDTERMINAL
        while len(seen) <= d:
            seen.append({})
        old = seen[d].get(s)
        if old is not None and old >= G:
            return
        seen[d][s] = G
        terminals.append((s, d, G, c, parent, action, source, plan))

    def new_node(s, parent, action, d, G, c) -> int:
        nid = len(n_state)
        n_state.append(s)
        n_parent.append(parent)
        n_action.append(action)
        n_depth.append(d)
        n_G.append(G)
        n_cost.append(c)
        return nid

    def expansion_of(s):
        """[(action, next state, cost, completes τ)] of a state, computed once per state."""
        nonlocal t_sim
        out = succ_cache.get(s)
        if out is None:
            t0 = clock()
            out = succ_cache[s] = [(a, s2, k, goal(s2)) for a, s2, k in successors(s)]
            t_sim += clock() - t0
        return out

    def width_of(s, added=None):
        """WIDTH(s; A, P), cached per state while the tables are unchanged (not novel is for good)."""
        nonlocal t_nov
        hit = w_cache.get(s)
        if hit is not None and (hit[1] is None or hit[0] == tables.version):
            return hit[1]
        t0 = clock()
        w = width(s, added)
        t_nov += clock() - t0
        w_cache[s] = (tables.version, w)
        return w

    # -- lines 2-3: the myopic reference terminal, admitted first -------------------------------
    c_myo = None
    if reference_plan is not None:
        t0 = clock()
        s, d, G, c, prefix = _reference_terminal(model, state, task, goal, reference_plan, gamma, scale)
        t_sim += clock() - t0
        admit_terminal(s, d, G, c, -1, None, "reference", prefix)
        c_myo = c

    # -- line 4: ENQUEUE the root (a root that already completes τ is a terminal with the empty plan)
    if goal(state):
        admit_terminal(state, 0, 0.0, 0, -1, None, "search", [])
    elif depth_cap > 0:
        seen[0][state] = 0.0
        root = new_node(state, -1, None, 0, 0.0, 0)
        pending.append((root, next(tick)))
        w = width_of(state)
        if w is not None:
            heappush(h_novelty, (w, 0, next(tick), root))

    def expand(nid, registered):                                            # EXPAND
        s, d, G, c = n_state[nid], n_depth[nid], n_G[nid], n_cost[nid]
        expanded[d][s] = G
        succ = expansion_of(s)
        d1 = d + 1
        disc = gpow[d] / scale
        is_open = d1 < depth_cap
        seen_d1 = seen[d1] if is_open else None
        for a, s2, k, hit in succ:
            G2 = G - disc * k
            if hit:
                admit_terminal(s2, d1, G2, c + k, nid, a, "search")
                continue
            if not is_open:                                                  # ENQUEUE line 2
                continue
            old = seen_d1.get(s2)
            if old is not None and G2 <= old:                               # ENQUEUE line 3
                continue
            seen_d1[s2] = G2                                                 # line 4
            child = len(n_state)
            n_state.append(s2)
            n_parent.append(nid)
            n_action.append(a)
            n_depth.append(d1)
            n_G.append(G2)
            n_cost.append(c + k)
            pending.append((child, next(tick)))          # line 5: on H_B with this counter at the next flush
            w = width_of(s2, s2 & ~s if registered else None)                # line 6
            if w is not None:
                heappush(h_novelty, (w, d1, next(tick), child))
        stats.generated += len(succ)

    def flush():
        """Value the pending nodes (one batched call) and push them on H_B with their enqueue counters."""
        nonlocal t_val, value_calls, value_states
        need = list(dict.fromkeys(n_state[nid] for nid, _ in pending if n_state[nid] not in q_cache))
        if need and prefetch > len(need):
            # The children of these states are the likely next pushes: value them in the same call.
            extra = dict.fromkeys(s2 for s in need for _, s2, _, hit in expansion_of(s)
                                  if not hit and s2 not in q_cache)
            for s in need:
                extra.pop(s, None)
            need += list(extra)[:prefetch - len(need)]
        if need:
            t0 = clock()
            q = value.q_max(need, task)
            t_val += clock() - t0
            value_calls += 1
            value_states += len(need)
            q_cache.update(zip(need, np.asarray(q, dtype=float).tolist()))
        for nid, k in pending:
            heappush(h_bellman, (-(n_G[nid] + gpow[n_depth[nid]] * q_cache[n_state[nid]]), k, nid))
        pending.clear()

    def novelty_pop():                                                      # NOVELTYPOP
        while h_novelty:
            w_old, d, _, nid = heappop(h_novelty)
            s = n_state[nid]
            if d >= depth_cap or expanded[d].get(s, -INF) >= n_G[nid]:
                stats.novelty_skipped += 1
                continue
            w = width_of(s)
            if w is None:
                stats.novelty_dropped += 1
                continue
            if w > w_old:
                heappush(h_novelty, (w, d, next(tick), nid))
                stats.novelty_repushed += 1
                continue
            return nid
        return None

    # -- lines 5-18: the loop ----------------------------------------------------------------------
    e, phase = 0, 0
    while e < budget and (h_bellman or pending or h_novelty):
        if phase < BELLMAN_TURNS:                                           # Bellman turn
            phase = (phase + 1) % (BELLMAN_TURNS + 1)
            if pending:
                flush()
            if not h_bellman:
                stats.forfeited += 1
                if trace is not None:
                    trace.append(("forfeit",))
                continue
            _, _, nid = heappop(h_bellman)
            d = n_depth[nid]
            if d >= depth_cap or expanded[d].get(n_state[nid], -INF) >= n_G[nid]:   # STALE
                stats.stale += 1
                if trace is not None:
                    trace.append(("stale", n_state[nid], d))
                continue
            e += 1
            stats.bellman_expansions += 1
            if trace is not None:
                trace.append(("bellman", n_state[nid], d))
            expand(nid, False)
        else:                                                               # novelty turn
            phase = 0
            nid = novelty_pop()
            if nid is None:
                continue
            t0 = clock()
            register(n_state[nid])                                          # line 15: tables grow only here
            t_nov += clock() - t0
            e += 1
            stats.novelty_expansions += 1
            if trace is not None:
                trace.append(("novelty", n_state[nid], n_depth[nid]))
            expand(nid, True)

    # -- line 19: SELECTTERMINAL -----------------------------------------------------------------
    stats.expansions, stats.nodes = e, len(n_state)
    stats.value_seconds, stats.value_calls, stats.value_states = t_val, value_calls, value_states
    stats.simulator_seconds, stats.novelty_seconds = t_sim, t_nov
    return _select(terminals, c_myo, beta, task, value.v_ap, stats, lambda t: _plan_of(t, n_parent, n_action),
                   t_start)


def _reference_terminal(model, state: int, task, goal, reference_plan: list, gamma: float, scale: float):
    """Lines 2-3: the myopic reference plan replayed from the root and cut where τ first holds:
    (state, depth, G, cost, prefix)."""
    s, G, c, prefix = state, 0.0, 0, []
    if not goal(s):
        for a in reference_plan:
            k = model.action_cost[a]
            G -= gamma ** len(prefix) * k / scale
            s = model.apply(s, a)
            c += k
            prefix.append(a)
            if goal(s):
                break
        else:
            raise ValueError(f"the reference plan does not complete {getattr(task, 'name', task)}")
    return s, len(prefix), G, c, prefix


def _select(terminals: list, c_myo, beta: float, task, v_ap, stats: BNStats, plan_of, t_start: float) -> BNResult:
    """Line 19, SELECTTERMINAL: V_AP of the eligible terminals' post-consumption states in one call, then Eq. 4.1.

    terminals: (state, depth, G, cost, parent, action, source, plan) in discovery order; v_ap: the
    value's V_AP; plan_of(terminal): its action list. Fills the stats' choice, terminal counts and times
    (simulator and value times add).
    """
    clock = time.perf_counter
    if c_myo is None and terminals:
        c_myo = min(t[3] for t in terminals)
    bound = beta * c_myo if c_myo is not None else None
    eligible = [i for i, t in enumerate(terminals) if _within(t[3], bound)] if terminals else []
    t0 = clock()
    after = {i: task.consume(terminals[i][0]) for i in eligible}
    stats.simulator_seconds += clock() - t0
    v_cache: dict = {}
    need = list(dict.fromkeys(after.values()))
    if need:
        t0 = clock()
        v = v_ap(need)
        stats.value_seconds += clock() - t0
        stats.value_calls += 1
        stats.value_states += len(need)
        v_cache = dict(zip(need, np.asarray(v, dtype=float).tolist()))
    out = [Terminal(t[6], t[3], t[1], t[2], t[0], v_cache[after[i]] if i in after else None)
           for i, t in enumerate(terminals)]
    chosen = select_terminal(out, c_myo, beta)
    plan = None
    if chosen is not None:
        plan = plan_of(terminals[chosen])
        stats.source, stats.v_ap = out[chosen].source, out[chosen].v_ap
        stats.cost, stats.depth = out[chosen].cost, out[chosen].depth
    stats.c_myo, stats.terminals, stats.eligible = c_myo, len(terminals), len(eligible)
    stats.seconds = time.perf_counter() - t_start
    return BNResult(plan, stats, out)


def _plan_of(terminal, n_parent, n_action) -> list:
    """The action sequence of a terminal: its stored plan, or the parent chain of its node plus its last action."""
    s, d, G, c, parent, action, source, plan = terminal
    if plan is not None:
        return list(plan)
    out = [action]
    while parent >= 0 and n_parent[parent] >= 0:
        out.append(n_action[parent])
        parent = n_parent[parent]
    return out[::-1]


def _n_atoms(model, state: int) -> int:
    atoms = getattr(model, "atoms", None)
    return len(atoms) if atoms is not None else state.bit_length()


# ---- the compiled loop (_bn.c) ---------------------------------------------------------------------------
_P = ctypes.c_void_p
_I64 = ctypes.c_int64


class _ModelSpec(ctypes.Structure):
    """bn_model of _bn.c: the successor index as arrays, and the current task's goal."""

    _fields_ = [("W", _I64), ("n_atoms", _I64), ("n_actions", _I64), ("n_entries", _I64),
                ("e_pos", _P), ("e_neg", _P), ("e_add", _P), ("e_del", _P),
                ("e_action", _P), ("e_cost", _P), ("e_multi", _P), ("e_cond0", _P), ("e_condn", _P),
                ("c_pos", _P), ("c_neg", _P), ("c_add", _P), ("c_del", _P),
                ("n_always", _I64), ("trig0", _P), ("n_goals", _I64), ("g_pos", _P), ("g_neg", _P)]


class _Stats(ctypes.Structure):
    _fields_ = [(k, _I64) for k in ("expansions", "bellman", "novelty", "forfeited", "stale", "skipped", "dropped",
                                    "repushed", "generated", "nodes", "terminals", "value_calls", "value_states",
                                    "states", "trace")] + [(k, ctypes.c_double) for k in ("t_sim", "t_nov", "t_val")]


_LIB = None
_MODELS: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()
MAX_WORDS = 64                     # _bn.c's limit: 4,096 atoms


def _lib():
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


class _Kernel:
    """A compiled model's successor index for _bn.c (arrays kept alive here), and the goals of its tasks."""

    def __init__(self, model):
        W = self.W = max(1, -(-len(model.atoms) // 64))
        self.n_atoms, self.n_actions = len(model.atoms), len(model.actions)
        words = lambda masks: np.frombuffer(b"".join(m.to_bytes(8 * W, "little") for m in masks) or b"",
                                            dtype="<u8").copy() if masks else np.zeros(W, "<u8")
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
            "e_pos": words([o.pos for o in ops]), "e_neg": words([o.neg for o in ops]),
            "e_add": words([o.add for o in ops]), "e_del": words([o.dele for o in ops]),
            "e_action": np.array(acts, np.int32), "e_cost": np.array([model.action_cost[x] for x in acts], np.int64),
            "e_multi": np.array([counts[x] > 1 for x in acts], np.uint8),
            "e_cond0": np.array(cond0, np.int32), "e_condn": np.array(condn, np.int32),
            "c_pos": words([c[0] for c in conds]), "c_neg": words([c[1] for c in conds]),
            "c_add": words([c[2] for c in conds]), "c_del": words([c[3] for c in conds]),
            "trig0": np.array(trig0, np.int32)}
        if not len(a["e_action"]):
            a["e_action"], a["e_cost"] = np.zeros(1, np.int32), np.zeros(1, np.int64)
            a["e_multi"], a["e_cond0"], a["e_condn"] = np.zeros(1, np.uint8), np.zeros(1, np.int32), np.zeros(1, np.int32)
        self.spec = _ModelSpec(W=W, n_atoms=self.n_atoms, n_actions=self.n_actions, n_entries=len(ops),
                               n_always=len(groups.get(-1, [])),
                               **{k: _ptr(v) for k, v in a.items()})
        self.goals: dict = {}

    def words(self, states) -> np.ndarray:
        W = self.W
        return np.frombuffer(b"".join(s.to_bytes(8 * W, "little") for s in states), dtype="<u8").copy()

    def ints(self, words: np.ndarray, n: int) -> list:
        raw, k = words.tobytes(), 8 * self.W
        return [int.from_bytes(raw[i * k:(i + 1) * k], "little") for i in range(n)]

    def with_goal(self, task) -> _ModelSpec:
        """The spec with this task's goal (any binding's (pos, neg) holds)."""
        g = self.goals.get(task.index)
        if g is None:
            g = self.goals[task.index] = (self.words([b.pos for b in task.bindings]),
                                          self.words([b.neg for b in task.bindings]), len(task.bindings))
        spec = _ModelSpec.from_buffer_copy(self.spec)
        spec.g_pos, spec.g_neg, spec.n_goals = _ptr(g[0]), _ptr(g[1]), g[2]
        return spec

    def successors(self, lib, state: int, task) -> list:
        """[(action, next state, cost, completes τ)] of a state as the compiled loop computes them."""
        spec = self.with_goal(task)
        one = np.ones(1)
        h = lib.bn_new(ctypes.addressof(spec), 0, 0, _ptr(one), 1.0, 0, 0, 0, 0)
        try:
            cap = self.n_actions + 1
            act, cost = np.zeros(cap, np.int32), np.zeros(cap, np.int64)
            nxt, hit = np.zeros(cap * self.W, "<u8"), np.zeros(cap, np.uint8)
            s = self.words([state])                   # kept alive through the call
            n = lib.bn_successors(h, _ptr(s), _ptr(act), _ptr(cost), _ptr(nxt), _ptr(hit), cap)
            return list(zip(act[:n].tolist(), self.ints(nxt, n), cost[:n].tolist(), hit[:n].astype(bool).tolist()))
        finally:
            lib.bn_free(h)


def _kernel_for(model, task, state: int):
    """The compiled model for this search, or None where the C loop does not apply."""
    lib = _lib()
    if lib is None or not getattr(task, "bindings", None) or not hasattr(task, "index"):
        return None
    k = _MODELS.get(model) if _weakrefable(model) else None
    if k is None:
        k = _build_kernel(lib, model, task, state)
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


def _build_kernel(lib, model, task, state: int):
    """A _Kernel for a compiled model whose successors it reproduces exactly, else False (None: not a model)."""
    from planning.domain.model import Model
    if not isinstance(model, Model) or type(model).successors is not Model.successors \
            or "successors" in vars(model):
        return None
    if getattr(model, "axioms", None) is not None or len(model.atoms) > 64 * MAX_WORDS \
            or not all(isinstance(c, Integral) for c in model.action_cost):
        return False
    try:
        k = _Kernel(model)
        probes = [model.init, state] + model.random_walk_states(24, 0, walk=12)
    except Exception:                       # noqa: BLE001 - anything unexpected: the Python loop
        return False
    for s in probes:                        # the compiled successors must be Model.successors, in order
        want = [(a, t, c, bool(task.satisfied(t))) for a, t, c in model.successors(s)]
        if k.successors(lib, s, task) != want:
            return False
    return k


def _search_c(k: _Kernel, model, state: int, task, value, *, budget: int, beta: float, depth_cap: int,
              reference_plan: list | None, gamma: float, scale: float, trace: list | None, prefetch: int,
              native_value: bool) -> BNResult:
    """Algorithms 3-4 with the loop in C; the reference replay and the selection as in Python."""
    t_start = time.perf_counter()
    clock = time.perf_counter
    lib = _lib()
    stats = BNStats()
    goal = _goal_test(task)
    cap = max(depth_cap, 0)
    gpow = np.array([gamma ** d for d in range(cap + 1)], dtype=np.float64)
    fast = None
    if native_value and callable(getattr(value, "native_q_max", None)):
        fast = value.native_q_max(task)          # None where the value has no compiled form here
        if fast is not None and getattr(fast, "model", model) is not model:
            fast = None                              # compiled for another model: the value's own q_max
    spec = k.with_goal(task)
    h = lib.bn_new(ctypes.addressof(spec), int(budget), int(depth_cap), _ptr(gpow), float(scale),
                   int(prefetch) if fast is None else NATIVE_PREFETCH, int(task.index), 1, int(trace is not None))
    if not h:
        raise MemoryError("the compiled Bellman–Novelty search could not allocate its tables")
    try:
        if fast is not None:
            lib.bn_set_native(h, fast.fn, fast.ctx)
        terminals: list = []
        c_myo = None
        ref = None
        if reference_plan is not None:
            t0 = clock()
            ref = _reference_terminal(model, state, task, goal, reference_plan, gamma, scale)
            stats.simulator_seconds += clock() - t0
            c_myo = ref[3]
        root = k.words([state])
        rs = k.words([ref[0]]) if ref is not None else root
        if lib.bn_start(h, _ptr(root), int(ref is not None), _ptr(rs), ref[1] if ref else 0,
                        ref[2] if ref else 0.0, ref[3] if ref else 0) < 0:
            raise MemoryError("the compiled Bellman–Novelty search ran out of memory")
        rc = lib.bn_run(h)
        ps, pq = _P(), _P()
        while rc == 1:                             # a Python value: value the flush's states, resume
            n = lib.bn_need(h, ctypes.byref(ps), ctypes.byref(pq))
            need = k.ints(np.ctypeslib.as_array(ctypes.cast(ps, ctypes.POINTER(ctypes.c_uint64)), (n * k.W,)), n)
            t0 = clock()
            q = np.asarray(value.q_max(need, task), dtype=np.float64)
            lib.bn_add_value_time(h, clock() - t0)
            np.ctypeslib.as_array(ctypes.cast(pq, ctypes.POINTER(ctypes.c_double)), (n,))[:] = q
            rc = lib.bn_run(h)
        if rc == -2:
            raise ValueError("the value's compiled q_max refused the search's states or task (another model?)")
        if rc < 0:
            raise MemoryError("the compiled Bellman–Novelty search ran out of memory (or past 2^32 pushes)")
        st = _Stats()
        lib.bn_get_stats(h, ctypes.byref(st))
        nt = st.terminals
        t_states, t_depth, t_G = np.zeros(max(nt, 1) * k.W, "<u8"), np.zeros(max(nt, 1), np.int32), np.zeros(max(nt, 1))
        t_cost, t_parent, t_action = np.zeros(max(nt, 1), np.int64), np.zeros(max(nt, 1), np.int32), np.zeros(max(nt, 1), np.int32)
        lib.bn_get_terminals(h, _ptr(t_states), _ptr(t_depth), _ptr(t_G), _ptr(t_cost), _ptr(t_parent), _ptr(t_action))
        t_s = k.ints(t_states, nt)
        for i, (s, d, G, c, par, act) in enumerate(zip(t_s, t_depth[:nt].tolist(), t_G[:nt].tolist(),
                                                      t_cost[:nt].tolist(), t_parent[:nt].tolist(),
                                                      t_action[:nt].tolist())):
            if i == 0 and ref is not None:
                terminals.append((s, d, G, c, -1, None, "reference", ref[4]))
            elif par < 0:
                terminals.append((s, d, G, c, -1, None, "search", []))      # the root completes τ
            else:
                terminals.append((s, d, G, c, par, act, "search", None))
        if trace is not None and st.trace:
            kinds, tr_s, tr_d = np.zeros(st.trace, np.int8), np.zeros(st.trace * k.W, "<u8"), np.zeros(st.trace, np.int32)
            lib.bn_get_trace(h, _ptr(kinds), _ptr(tr_s), _ptr(tr_d))
            names = ("bellman", "novelty", "forfeit", "stale")
            for kind, s, d in zip(kinds.tolist(), k.ints(tr_s, st.trace), tr_d.tolist()):
                trace.append((names[kind],) if kind == 2 else (names[kind], s, d))
        buf = np.zeros(max(cap, 1) + 1, np.int32)

        def plan_of(t):
            if t[7] is not None:
                return list(t[7])
            n = lib.bn_plan(h, t[4], _ptr(buf), len(buf))
            return buf[:n][::-1].tolist() + [t[5]]

        stats.expansions, stats.bellman_expansions, stats.novelty_expansions = st.expansions, st.bellman, st.novelty
        stats.forfeited, stats.stale, stats.novelty_skipped = st.forfeited, st.stale, st.skipped
        stats.novelty_dropped, stats.novelty_repushed = st.dropped, st.repushed
        stats.generated, stats.nodes = st.generated, st.nodes
        stats.value_seconds, stats.value_calls, stats.value_states = st.t_val, st.value_calls, st.value_states
        stats.simulator_seconds += st.t_sim
        stats.novelty_seconds = st.t_nov
        v_ap = getattr(fast, "v_ap", None) or value.v_ap        # the compiled value's V_AP with its q_max
        return _select(terminals, c_myo, beta, task, v_ap, stats, plan_of, t_start)
    finally:
        lib.bn_free(h)
