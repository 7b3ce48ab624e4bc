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

The modules: `planning.search.expansion` (the node set, its ledgers, EXPAND),
`planning.search.frontiers` (H_B and H_N), `planning.search.novelty` (the
width tables), `planning.search.terminals` (the reference terminal, V_AP
scoring, Eq. 4.1), `planning.search.bn_stats` (what a search did). Two
implementations of the loop, the same turn for turn: the Python loop below,
for any model and value, and the compiled loop (`planning.search.bn_kernel`,
planning/search/_bn.c) for a compiled model (`planning.domain.model.Model`
without derived predicates) and a task with goal bindings, which with the
same value makes the same choices bit for bit
(tests/planning/test_bn_kernel.py) and calls a value's compiled q_max from C
where it has one. Without a C compiler, or with `ANTICIPATORY_BN_NATIVE=0`,
the Python loop runs. `kernel=` ("auto", "c", "python") and `native_value=`
force a path. The loop before the kernel is kept verbatim in
`planning.search.bellman_novelty_reference` (the benchmark's reference).
Measured with `learning.agents.bench_bn`: results/bench-bn-*.json.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass, field

from planning.search.bn_kernel import CompiledSearch, kernel_for
from planning.search.bn_stats import BNStats
from planning.search.expansion import SearchTree, goal_test
from planning.search.frontiers import BellmanFrontier, NoveltyFrontier
from planning.search.terminals import (
    Terminal,
    reference_terminal,
    score_eligible,
    select_terminal,
)

BELLMAN_TURNS = 3  # Bellman turns per novelty turn (Algorithm 3, lines 6-16)
DEPTH_CAP = 20  # d_max of Table A.3
PREFETCH = 64  # most states per q_max call when a flush speculatively values grandchildren


@dataclass
class BNResult:
    plan: list | None  # ground action indices of the chosen terminal; None: no selection
    stats: BNStats
    terminals: list = field(default_factory=list)  # every Terminal, in discovery order


def bellman_novelty_search(
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
    kernel: str = "auto",
    native_value: bool = True,
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
        scale = float(getattr(model, "cost_scale", 1))  # a stand-in model without one: PDDL units
    if beta < 1:
        raise ValueError(f"beta must be at least 1 (got {beta}): the reference must stay eligible")
    if kernel not in ("auto", "c", "python"):
        raise ValueError(f"kernel must be 'auto', 'c' or 'python', not {kernel!r}")
    compiled = kernel_for(model, task, state) if kernel != "python" else None
    if compiled is None and kernel == "c":
        raise RuntimeError(
            "the compiled search does not apply here (no C compiler, "
            "ANTICIPATORY_BN_NATIVE=0, or not a compiled model and task)"
        )
    t_start = time.perf_counter()
    stats = BNStats()
    goal = goal_test(task)
    reference, prefix = None, None
    if reference_plan is not None:  # lines 2-3: the myopic reference terminal
        t0 = time.perf_counter()
        reference, prefix = reference_terminal(model, state, task, goal, reference_plan, gamma, scale)
        stats.simulator_seconds += time.perf_counter() - t0
    if compiled is None:
        tree = _run_python(
            model,
            state,
            task,
            value,
            goal,
            reference,
            budget=budget,
            depth_cap=depth_cap,
            gamma=gamma,
            scale=scale,
            trace=trace,
            prefetch=prefetch,
            stats=stats,
        )
        return _result(tree, reference, prefix, beta, task, value.v_ap, stats, t_start)
    with CompiledSearch(
        compiled,
        model,
        task,
        value,
        budget=budget,
        depth_cap=depth_cap,
        gamma=gamma,
        scale=scale,
        prefetch=prefetch,
        native_value=native_value,
        tracing=trace is not None,
    ) as search:
        search.run(state, reference, stats, trace)
        return _result(search, reference, prefix, beta, task, search.v_ap, stats, t_start)


def _run_python(
    model,
    state: int,
    task,
    value,
    goal,
    reference: Terminal | None,
    *,
    budget: int,
    depth_cap: int,
    gamma: float,
    scale: float,
    trace: list | None,
    prefetch: int,
    stats: BNStats,
) -> SearchTree:
    """Lines 2-18 in Python, for any model and value: the tree with its terminals; fills the stats' counts."""
    tree = SearchTree(model, goal, depth_cap, gamma, scale, stats)
    tick = itertools.count()  # NEXT: push order, the FIFO tie-break of both heaps
    bellman = BellmanFrontier(tree, value, task, tick, prefetch, stats)
    novelty = NoveltyFrontier(tree, _n_atoms(model, state), tick, stats)
    if reference is not None:  # admitted first
        tree.admit_terminal(reference.state, reference.depth, reference.G, reference.cost, -1, None, "reference")

    # -- line 4: ENQUEUE the root (a root that already completes τ is a terminal with the empty plan)
    if goal(state):
        tree.admit_terminal(state, 0, 0.0, 0, -1, None, "search")
    elif depth_cap > 0:
        tree.seen[0][state] = 0.0
        root = tree.add_node(state, -1, None, 0, 0.0, 0)
        bellman.enqueue(root)
        novelty.offer(root, state, 0)

    # -- lines 5-18: the turns; only real expansions count toward the budget -------------------------
    e, phase = 0, 0
    while e < budget and (bellman.heap or bellman.pending or novelty.heap):
        if phase < BELLMAN_TURNS:  # Bellman turn
            phase = (phase + 1) % (BELLMAN_TURNS + 1)
            nid = bellman.pop()
            if nid is None:  # an empty heap forfeits the turn
                stats.forfeited += 1
                if trace is not None:
                    trace.append(("forfeit",))
                continue
            if tree.is_stale(nid):  # so does a stale pop
                stats.stale += 1
                if trace is not None:
                    trace.append(("stale", tree.state[nid], tree.depth[nid]))
                continue
            e += 1
            stats.bellman_expansions += 1
            if trace is not None:
                trace.append(("bellman", tree.state[nid], tree.depth[nid]))
            tree.expand(nid, False, bellman, novelty)
        else:  # novelty turn
            phase = 0
            nid = novelty.pop()
            if nid is None:
                continue
            novelty.register(tree.state[nid])
            e += 1
            stats.novelty_expansions += 1
            if trace is not None:
                trace.append(("novelty", tree.state[nid], tree.depth[nid]))
            tree.expand(nid, True, bellman, novelty)
    stats.expansions, stats.nodes = e, len(tree.state)
    return tree


def _result(
    search, reference: Terminal | None, prefix: list | None, beta: float, task, v_ap, stats: BNStats, t_start: float
) -> BNResult:
    """Line 19, SELECTTERMINAL: score the eligible terminals of `search` (a SearchTree or a CompiledSearch:
    its `terminals` and `plan(i)`), choose by Eq. 4.1, fill the stats' choice and counts."""
    terminals, c_myo, eligible = score_eligible(
        search.terminals, reference.cost if reference else None, beta, task, v_ap, stats
    )
    chosen = select_terminal(terminals, c_myo, beta)
    plan = None
    if chosen is not None:
        t = terminals[chosen]
        plan = list(prefix) if t.source == "reference" else search.plan(chosen)
        stats.source, stats.v_ap, stats.cost, stats.depth = t.source, t.v_ap, t.cost, t.depth
    stats.c_myo, stats.terminals, stats.eligible = c_myo, len(terminals), eligible
    stats.seconds = time.perf_counter() - t_start
    return BNResult(plan, stats, terminals)


def _n_atoms(model, state: int) -> int:
    atoms = getattr(model, "atoms", None)
    return len(atoms) if atoms is not None else state.bit_length()
