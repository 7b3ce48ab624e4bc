"""The Bellman–Novelty search as it was before the compiled kernel: the reference it is measured against.

A verbatim copy of planning/search/bellman_novelty.py at commit 6ec6ff5 (only
the function renamed), kept unchanged: `learning.agents.bench_bn` reports the new
search's speed as a ratio against it measured in the same run, and the identity
tests check that the new search makes the same choices. Everything else uses
`planning.search.bellman_novelty`. The original module docstring follows.

Bellman–Novelty search (thesis §4.2, Appendix A.3, Algorithms 3 and 4), generic over a value.

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
"""

from __future__ import annotations

import heapq
import itertools
import time
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from planning.search.novelty import NoveltyTables

BELLMAN_TURNS = 3  # Bellman turns per novelty turn (Algorithm 3, lines 6-16)
DEPTH_CAP = 20  # d_max of Table A.3
PREFETCH = 64  # most states per q_max call when a flush speculatively values grandchildren
INF = float("inf")


class Terminal(NamedTuple):
    """A candidate completion of the current task, in discovery order."""

    source: str  # "reference" (the myopic plan) or "search"
    cost: float  # undiscounted PDDL cost of the prefix
    depth: int
    G: float  # discounted prefix return (RL units, ≤ 0)
    state: int  # the completing state, before consumption
    v_ap: float | None = None  # V_AP of the post-consumption state; None if not scored (ineligible)


@dataclass
class BNStats:
    """What a search did and chose; times in seconds."""

    c_myo: float | None = None  # the cost bound's reference
    terminals: int = 0  # candidate terminals admitted (the reference included)
    eligible: int = 0  # of which within β·C_myo
    expansions: int = 0  # charged to the budget
    bellman_expansions: int = 0
    novelty_expansions: int = 0
    forfeited: int = 0  # Bellman turns lost to an empty heap
    stale: int = 0  # Bellman turns lost to a stale pop
    novelty_skipped: int = 0  # stale novelty pops (the turn went on popping)
    novelty_dropped: int = 0  # no longer novel at pop
    novelty_repushed: int = 0  # width got worse at pop
    generated: int = 0  # successors generated
    nodes: int = 0  # open nodes admitted
    source: str | None = None  # of the chosen terminal
    v_ap: float | None = None  # of the chosen terminal
    cost: float | None = None
    depth: int | None = None
    seconds: float = 0.0
    value_seconds: float = 0.0  # q_max and V_AP calls
    value_calls: int = 0
    value_states: int = 0  # states valued (after the per-state caches)
    simulator_seconds: float = 0.0  # successors, goal tests, consumption, reference replay
    novelty_seconds: float = 0.0  # width tests and registration


@dataclass
class BNResult:
    plan: list | None  # ground action indices of the chosen terminal; None: no selection
    stats: BNStats
    terminals: list = field(default_factory=list)  # every Terminal, in discovery order


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
    return cost <= bound + 1e-9 * max(1.0, abs(bound))  # β·C in floats: 1.25 * 4 must admit 5


def _goal_test(task):
    """A fast `task.satisfied`: the goal's (pos, neg) masks inlined where the task exposes them."""
    bindings = getattr(task, "bindings", None)
    if not bindings:
        return task.satisfied
    goals = tuple((b.pos, b.neg) for b in bindings)
    if len(goals) == 1:
        ((pos, neg),) = goals
        return lambda s: s & pos == pos and not s & neg
    return lambda s: any(s & p == p and not s & n for p, n in goals)


def bellman_novelty_search_reference(
    model,
    state: int,
    task,
    value,
    *,
    budget: int,
    beta: float,
    depth_cap: int = DEPTH_CAP,
    reference_plan: list | None = None,
    gamma: float | None = None,
    scale: float | None = None,
    trace: list | None = None,
    prefetch: int = PREFETCH,
) -> BNResult:
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
    """
    t_start = time.perf_counter()
    clock = time.perf_counter
    if gamma is None:
        gamma = getattr(value, "gamma", None)
        if gamma is None:
            raise ValueError("the value has no gamma; pass gamma= to the search")
    if scale is None:
        scale = float(getattr(model, "cost_scale", 1))  # a stand-in model without one: PDDL units
    if beta < 1:
        raise ValueError(f"beta must be at least 1 (got {beta}): the reference must stay eligible")
    stats = BNStats()
    goal = _goal_test(task)
    successors = model.successors
    tables = NoveltyTables(_n_atoms(model, state))
    width, register = tables.width, tables.register
    heappush, heappop = heapq.heappush, heapq.heappop
    tick = itertools.count()  # NEXT: push order, the FIFO tie-break of both heaps

    # Nodes as parallel lists indexed by node id (no object per node).
    n_state, n_parent, n_action, n_depth, n_G, n_cost = [], [], [], [], [], []
    seen = [{} for _ in range(max(depth_cap, 0) + 1)]  # per depth: state -> best G admitted
    expanded = [{} for _ in range(max(depth_cap, 0) + 1)]  # per depth: state -> G when expanded
    gpow = [gamma**k for k in range(max(depth_cap, 0) + 1)]
    terminals: list = []  # (state, depth, G, cost, parent, action, source, plan)
    h_bellman, h_novelty = [], []
    pending: list = []  # (node, counter) enqueued but not yet valued and pushed on H_B
    q_cache: dict = {}  # state -> q_max(state, τ)
    succ_cache: dict = {}  # state -> its expansion_of list
    w_cache: dict = {}  # state -> (tables version, width)
    t_sim = t_nov = t_val = 0.0
    value_calls = value_states = 0

    def admit_terminal(s, d, G, c, parent, action, source, plan=None):  # TRYADDTERMINAL
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
        t_sim += clock() - t0
        admit_terminal(s, len(prefix), G, c, -1, None, "reference", prefix)
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

    def expand(nid, registered):  # EXPAND
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
            if not is_open:  # ENQUEUE line 2
                continue
            old = seen_d1.get(s2)
            if old is not None and G2 <= old:  # ENQUEUE line 3
                continue
            seen_d1[s2] = G2  # line 4
            child = len(n_state)
            n_state.append(s2)
            n_parent.append(nid)
            n_action.append(a)
            n_depth.append(d1)
            n_G.append(G2)
            n_cost.append(c + k)
            pending.append((child, next(tick)))  # line 5: on H_B with this counter at the next flush
            w = width_of(s2, s2 & ~s if registered else None)  # line 6
            if w is not None:
                heappush(h_novelty, (w, d1, next(tick), child))
        stats.generated += len(succ)

    def flush():
        """Value the pending nodes (one batched call) and push them on H_B with their enqueue counters."""
        nonlocal t_val, value_calls, value_states
        need = list(dict.fromkeys(n_state[nid] for nid, _ in pending if n_state[nid] not in q_cache))
        if need and prefetch > len(need):
            # The children of these states are the likely next pushes: value them in the same call.
            extra = dict.fromkeys(
                s2 for s in need for _, s2, _, hit in expansion_of(s) if not hit and s2 not in q_cache
            )
            for s in need:
                extra.pop(s, None)
            need += list(extra)[: prefetch - len(need)]
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

    def novelty_pop():  # NOVELTYPOP
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
        if phase < BELLMAN_TURNS:  # Bellman turn
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
            if d >= depth_cap or expanded[d].get(n_state[nid], -INF) >= n_G[nid]:  # STALE
                stats.stale += 1
                if trace is not None:
                    trace.append(("stale", n_state[nid], d))
                continue
            e += 1
            stats.bellman_expansions += 1
            if trace is not None:
                trace.append(("bellman", n_state[nid], d))
            expand(nid, False)
        else:  # novelty turn
            phase = 0
            nid = novelty_pop()
            if nid is None:
                continue
            t0 = clock()
            register(n_state[nid])  # line 15: tables grow only here
            t_nov += clock() - t0
            e += 1
            stats.novelty_expansions += 1
            if trace is not None:
                trace.append(("novelty", n_state[nid], n_depth[nid]))
            expand(nid, True)

    # -- line 19: SELECTTERMINAL -----------------------------------------------------------------
    if c_myo is None and terminals:
        c_myo = min(t[3] for t in terminals)
    bound = beta * c_myo if c_myo is not None else None
    eligible = [i for i, t in enumerate(terminals) if _within(t[3], bound)] if terminals else []
    t0 = clock()
    after = {i: task.consume(terminals[i][0]) for i in eligible}
    t_sim += clock() - t0
    v_cache: dict = {}
    need = list(dict.fromkeys(after.values()))
    if need:
        t0 = clock()
        v = value.v_ap(need)
        t_val += clock() - t0
        value_calls += 1
        value_states += len(need)
        v_cache = dict(zip(need, np.asarray(v, dtype=float).tolist()))
    out = [
        Terminal(t[6], t[3], t[1], t[2], t[0], v_cache[after[i]] if i in after else None)
        for i, t in enumerate(terminals)
    ]
    chosen = select_terminal(out, c_myo, beta)
    plan = None
    if chosen is not None:
        plan = _plan_of(terminals[chosen], n_parent, n_action)
        stats.source, stats.v_ap = out[chosen].source, out[chosen].v_ap
        stats.cost, stats.depth = out[chosen].cost, out[chosen].depth

    stats.c_myo, stats.terminals, stats.eligible, stats.expansions = c_myo, len(terminals), len(eligible), e
    stats.nodes = len(n_state)
    stats.value_seconds, stats.value_calls, stats.value_states = t_val, value_calls, value_states
    stats.simulator_seconds, stats.novelty_seconds = t_sim, t_nov
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
