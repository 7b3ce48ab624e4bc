"""The exact value of a small domain by value iteration over its reachable states (the value protocol).

The MDP is the learner's (thesis Eq. 3.1, Algorithm 1; `learning.reward`): an
action of PDDL cost c earns −c/scale, plus R_goal if it completes the task.
What follows a completion is the horizon's:

    myopic         Q(s, τ, a) = r                                  (the task's return alone)
    anticipatory   Q(s, τ, a) = r + γ V_AP(consume_τ(s'))          (the stream goes on)

and otherwise Q(s, τ, a) = r + γ max_a' Q(s', τ, a'). A task already satisfied
in s has one valid action, the trainer's AUTO pseudo-action (`learning.encoding`):
reward R_goal at zero cost, its consumption applied, then the same bootstrap as
any completion. V(s, τ) = max_a Q(s, τ, a) and V_AP(s) = Σ_τ P(τ) V(s, τ).

Episodes that end ([stream] terminal_reset): the trainer stores the completion
of the last task of an episode as terminal (y = r). With two tasks per reset
and a fixed first task (the minimal example, §5.1: clear C, then a delivery
drawn from P) the position of a task is known from the task: the drawn tasks
are always last, so their completion is terminal under both horizons, and the
first task's completion bootstraps V_AP over them (anticipatory). That is
`experiments.minimal_example.exact_placement_q`'s definition; longer terminal
episodes would need the position in the state and are refused.

`--value exact` (or `exact:myopic`) deploys it wherever a command takes a value
(`learning.values`). States: everything reachable from every world reset (each combination of the
[[reset]] choices) by actions and by the consumption of satisfied tasks.
Meant for small domains (the minimal grid has 100 states); `max_states` guards.
"""

from __future__ import annotations

from collections import deque
from itertools import product

import numpy as np

from learning.reward import cost_scale, goal_reward
from planning.errors import DomainError

HORIZONS = ("myopic", "anticipatory")


def reset_states(model) -> list[int]:
    """Every world a reset can draw: one state per combination of the [[reset]] choices with P > 0."""
    entries = [
        [(c, every) for c, p in zip(choices, probs) if p > 0]
        for choices, probs in model.resets
        for every in [_union(choices)]
    ]
    out = []
    for combo in product(*entries):
        s = model.init
        for choice, every in combo:
            s = (s & ~every) | choice
        out.append(s)
    return list(dict.fromkeys(out))


def _union(masks) -> int:
    out = 0
    for m in masks:
        out |= m
    return out


class ExactValue:
    """q_max and V_AP of the exact Q* by value iteration, for one horizon of a small domain."""

    def __init__(
        self,
        model,
        horizon: str = "anticipatory",
        gamma: float | None = None,
        r_goal: float | None = None,
        scale: float | None = None,
        roots=(),
        tol: float = 1e-11,
        max_iter: int = 200_000,
        max_states: int = 200_000,
    ):
        if horizon not in HORIZONS:
            raise DomainError("horizon", f"'{horizon}' is neither myopic nor anticipatory")
        self.model, self.horizon = model, horizon
        self.gamma = float(gamma if gamma is not None else model.config.get("reward", {}).get("gamma", 0.97))
        self.r_goal = float(r_goal if r_goal is not None else goal_reward(model))
        self.scale = float(scale if scale is not None else cost_scale(model))
        if not 0 <= self.gamma < 1:
            raise DomainError(
                model.files.get("config", model.name), f"value iteration needs gamma < 1, not {self.gamma}"
            )
        self.tasks = list(model.tasks)
        p = np.asarray(model.tasks.probabilities, dtype=float)
        self.p = p / p.sum()
        self.bootstrap = self._bootstraps()
        self._enumerate(list(roots), max_states)
        self.iterations = self._iterate(tol, max_iter)

    @classmethod
    def load(cls, horizon, model) -> "ExactValue":
        """The value registry's hook (`learning.values`): `exact` (anticipatory) or `exact:HORIZON`."""
        return cls(model, horizon or "anticipatory")

    @staticmethod
    def record(horizon) -> dict:
        """What a results file records of it: the horizon (γ, R_goal and the scale are the domain's)."""
        return {"value": "exact (learning.values.exact)", "horizon": horizon or "anticipatory"}

    # ---- the MDP ---------------------------------------------------------
    def _bootstraps(self) -> np.ndarray:
        """Per task: does its completion bootstrap γ V_AP (else it is terminal)?"""
        m = len(self.tasks)
        if self.horizon == "myopic":
            return np.zeros(m, dtype=bool)
        stream = self.model.config.get("stream", {})
        if not stream.get("terminal_reset", False):
            return np.ones(m, dtype=bool)
        first = stream.get("first_task")
        if stream.get("tasks_per_reset") != 2 or not first:
            raise DomainError(
                self.model.files.get("config", self.model.name),
                "exact values of terminal episodes need tasks_per_reset = 2 and a first_task "
                "(a task's position in the episode is otherwise not known from the task)",
            )
        first = self.model.tasks.get(first)
        if self.p[first.index] > 0:
            raise DomainError(
                self.model.files.get("config", self.model.name),
                f"first task {first.name} is also drawn from P: its value depends on its position",
            )
        out = np.zeros(m, dtype=bool)
        out[first.index] = True  # the first task bootstraps V_AP over the (terminal) drawn tasks
        return out

    def _enumerate(self, roots: list, max_states: int) -> None:
        model, tasks = self.model, self.tasks
        frontier = deque(dict.fromkeys(reset_states(model) + roots))
        index = {s: i for i, s in enumerate(frontier)}
        states = list(frontier)
        src, dst, cost = [], [], []

        def visit(s):
            if s not in index:
                if len(states) >= max_states:
                    raise DomainError(model.name, f"more than {max_states} reachable states: too big for ExactValue")
                index[s] = len(states)
                states.append(s)
                frontier.append(s)
            return index[s]

        while frontier:
            s = frontier.popleft()
            i = index[s]
            for _, s2, c in model.successors(s):
                src.append(i)
                dst.append(visit(s2))
                cost.append(c)
            for t in tasks:
                if t.satisfied(s):
                    visit(t.consume(s))
        n, m = len(states), len(tasks)
        self.states, self.index = states, index
        self.sat = np.array([[t.satisfied(s) for t in tasks] for s in states], dtype=bool).reshape(n, m)
        self.cons = np.array(
            [[index[t.consume(s)] if self.sat[i, k] else i for k, t in enumerate(tasks)] for i, s in enumerate(states)],
            dtype=np.int64,
        ).reshape(n, m)
        order = np.argsort(np.asarray(src, dtype=np.int64), kind="stable")
        self.src = np.asarray(src, dtype=np.int64)[order]
        self.dst = np.asarray(dst, dtype=np.int64)[order]
        self.reward = -np.asarray(cost, dtype=float)[order] / self.scale
        has = np.zeros(n, dtype=bool)
        has[self.src] = True
        dead = ~has[:, None] & ~self.sat
        if dead.any():
            i, k = map(int, np.argwhere(dead)[0])
            raise DomainError(
                tasks[k].name, f"a reachable state has no applicable action:\n{model.describe(states[i])}"
            )
        self.starts = np.flatnonzero(np.r_[True, self.src[1:] != self.src[:-1]]) if len(self.src) else np.zeros(0, int)
        self.rows = self.src[self.starts]

    def _completion(self, V: np.ndarray) -> np.ndarray:
        """(n, m): R_goal plus what follows completing τ in each state (γ V_AP of its consumption, or 0)."""
        vap = V @ self.p
        return self.r_goal + self.gamma * np.where(self.bootstrap[None, :], vap[self.cons], 0.0)

    def _backup(self, V: np.ndarray) -> np.ndarray:
        done = self._completion(V)
        nxt = np.where(self.sat[self.dst], done[self.dst], self.gamma * V[self.dst])  # (E, m)
        q = self.reward[:, None] + nxt
        out = np.full(V.shape, -np.inf)
        if len(q):
            out[self.rows] = np.maximum.reduceat(q, self.starts, axis=0)
        return np.where(self.sat, done, out)

    def _iterate(self, tol: float, max_iter: int) -> int:
        V = np.zeros((len(self.states), len(self.tasks)))
        for it in range(1, max_iter + 1):  # noqa: B007 (the sweeps it took are returned)
            new = self._backup(V)
            delta = np.max(np.abs(new - V)) if new.size else 0.0
            V = new
            if delta <= tol:
                break
        else:
            raise DomainError(self.model.name, f"value iteration did not converge in {max_iter} sweeps")
        self.V = V
        self.VAP = V @ self.p
        return it

    # ---- the value protocol ----------------------------------------------
    def _rows(self, states) -> np.ndarray:
        try:
            return np.fromiter((self.index[s] for s in states), dtype=np.int64, count=len(states))
        except KeyError as e:
            raise DomainError(
                self.model.name, f"state {e.args[0]:#x} is not reachable from a reset (pass it in roots=)"
            ) from None

    def q_max(self, states, task) -> np.ndarray:
        """max_a Q*(s, τ, a) per state (AUTO's value where τ already holds)."""
        k = task if isinstance(task, (int, np.integer)) else task.index
        return self.V[self._rows(states), k]

    def v_ap(self, states) -> np.ndarray:
        """V_AP(s) = Σ_τ P(τ) V*(s, τ) per state."""
        return self.VAP[self._rows(states)]

    def q(self, state: int, task, action: int | None) -> float:
        """Q*(s, τ, a) of one ground action (None: AUTO, valid only where τ already holds)."""
        k = task if isinstance(task, (int, np.integer)) else task.index
        t = self.tasks[k]
        i = self._rows([state])[0]
        done = self._completion(self.V)
        if action is None:
            if not self.sat[i, k]:
                raise DomainError(t.name, "AUTO is only valid where the task already holds")
            return float(done[i, k])
        if self.sat[i, k]:
            raise DomainError(t.name, "the task already holds: AUTO is the only valid action")
        nxt = self.model.apply(state, action)
        j = self._rows([nxt])[0]
        r = -self.model.action_cost[action] / self.scale
        return float(r + (done[j, k] if self.sat[j, k] else self.gamma * self.V[j, k]))
