"""The node set of the Bellman–Novelty search in Python and its expansion (thesis Algorithm 4, EXPAND, ENQUEUE).

A node is (state, parent, action, depth d, discounted prefix return G,
cost c), kept as parallel lists indexed by node id (no object per node). A
step from depth d with PDDL cost k gives G' = G − γ^d k / scale and
c' = c + k. `seen` maps (state, depth) to the best G admitted, checked before
a node is enqueued and before a terminal is admitted; `expanded` is the
expansion ledger that makes a pop stale. The depth cap gates open nodes only:
a completing successor is a terminal at any depth. A state's successors, with
their goal tests, are computed once per search.
"""

from __future__ import annotations

from heapq import heappush
from time import perf_counter

from planning.search.bn_stats import BNStats
from planning.search.terminals import Terminal

INF = float("inf")


def goal_test(task):
    """A fast `task.satisfied`: the goal's (pos, neg) masks inlined where the task exposes them."""
    bindings = getattr(task, "bindings", None)
    if not bindings:
        return task.satisfied
    goals = tuple((b.pos, b.neg) for b in bindings)
    if len(goals) == 1:
        ((pos, neg),) = goals
        return lambda s: s & pos == pos and not s & neg
    return lambda s: any(s & p == p and not s & n for p, n in goals)


class SearchTree:
    """The nodes, the (state, depth) ledgers and the terminals of one search."""

    def __init__(self, model, goal, depth_cap: int, gamma: float, scale: float, stats: BNStats):
        cap = max(depth_cap, 0)
        self.successors, self.goal, self.depth_cap, self.scale = model.successors, goal, depth_cap, scale
        self.stats = stats
        self.state: list = []
        self.parent: list = []
        self.action: list = []
        self.depth: list = []
        self.G: list = []
        self.cost: list = []
        self.seen = [{} for _ in range(cap + 1)]  # per depth: state -> best G admitted
        self.expanded = [{} for _ in range(cap + 1)]  # per depth: state -> G when expanded
        self.gpow = [gamma**k for k in range(cap + 1)]
        self.terminals: list = []  # Terminal, in discovery order
        self.terminal_node: list = []  # per terminal: the node it was reached from (-1: none)
        self.terminal_action: list = []  # per terminal: the action from that node
        self.succ_cache: dict = {}  # state -> [(action, next state, cost, completes τ)]

    def add_node(self, s: int, parent: int, action, d: int, G: float, c) -> int:
        nid = len(self.state)
        self.state.append(s)
        self.parent.append(parent)
        self.action.append(action)
        self.depth.append(d)
        self.G.append(G)
        self.cost.append(c)
        return nid

    def admit_terminal(self, s: int, d: int, G: float, c, node: int, action, source: str) -> None:
        """TRYADDTERMINAL: a terminal unless (s, d) was admitted with a G at least as high."""
        seen = self.seen
        while len(seen) <= d:
            seen.append({})
        old = seen[d].get(s)
        if old is not None and old >= G:
            return
        seen[d][s] = G
        self.terminals.append(Terminal(source, c, d, G, s))
        self.terminal_node.append(node)
        self.terminal_action.append(action)

    def successors_of(self, s: int) -> list:
        """[(action, next state, cost, completes τ)] of a state, computed once per search."""
        out = self.succ_cache.get(s)
        if out is None:
            t0 = perf_counter()
            goal = self.goal
            out = self.succ_cache[s] = [(a, s2, k, goal(s2)) for a, s2, k in self.successors(s)]
            self.stats.simulator_seconds += perf_counter() - t0
        return out

    def is_stale(self, nid: int) -> bool:
        """At the depth cap, or its (state, depth) already expanded with a G at least as high."""
        d = self.depth[nid]
        return d >= self.depth_cap or self.expanded[d].get(self.state[nid], -INF) >= self.G[nid]

    def expand(self, nid: int, registered: bool, bellman, novelty) -> None:
        """EXPAND: admit the completing successors as terminals, enqueue the others on both frontiers.

        The hot loop of the search: a child's fields and its pushes on the two
        frontiers (`add_node`, `BellmanFrontier.enqueue`, `NoveltyFrontier.offer`)
        are written out here rather than called. registered: the node's state
        was registered in the novelty tables just before (a novelty expansion),
        so a child's width is checked only on the pairs involving the atoms its
        action added.
        """
        n_state, n_parent, n_action = self.state, self.parent, self.action
        n_depth, n_G, n_cost = self.depth, self.G, self.cost
        s, d, G, c = n_state[nid], n_depth[nid], n_G[nid], n_cost[nid]
        self.expanded[d][s] = G
        succ = self.successors_of(s)
        d1 = d + 1
        disc = self.gpow[d] / self.scale
        is_open = d1 < self.depth_cap
        seen_d1 = self.seen[d1] if is_open else None
        admit = self.admit_terminal
        pending, tick, width, h_novelty = bellman.pending, bellman.tick, novelty.width, novelty.heap
        for a, s2, k, hit in succ:
            G2 = G - disc * k
            if hit:
                admit(s2, d1, G2, c + k, nid, a, "search")
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
            w = width(s2, s2 & ~s if registered else None)  # line 6
            if w is not None:
                heappush(h_novelty, (w, d1, next(tick), child))
        self.stats.generated += len(succ)

    def plan(self, i: int) -> list:
        """The actions of search terminal i: the path to the node it was reached from, then its action."""
        node = self.terminal_node[i]
        if node < 0:
            return []  # the root completes τ
        parent, action = self.parent, self.action
        out = [self.terminal_action[i]]
        while parent[node] >= 0:
            out.append(action[node])
            node = parent[node]
        return out[::-1]
