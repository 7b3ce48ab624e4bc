"""The value protocol: what a search or a candidate scorer asks of a value (thesis §4.2, SPEC "Values").

A value is anything that, for a batch of states of one compiled model, gives

    q_max(states, task) -> (N,) array   max_a Q(s, τ, a): how well placed s is to finish
                                        the *current* task τ (the Bellman lane's key)
    v_ap(states)        -> (N,) array   V_AP(s) = E_τ'~P[max_a Q(s, τ', a)]: how well
                                        prepared s is for the *next* task (terminal score)

Larger is better for both. `states` is a list of the model's int states, `task`
a `Task` of its distribution. A value may also offer a compiled q_max
(`native_q_max`, below), which the compiled Bellman–Novelty search calls from C
instead of `q_max`. Implementations, one row each in the value registry
(`learning.values`, which also builds them from a command line's `--value`):
the Q-network's value (`learning.q.value.ValueFunction`), the GNN estimate as
-C_AP, an exact value by value iteration on small domains, and `ZeroValue`
below, which makes the Bellman–Novelty search myopic: every terminal ties on
V_AP, so the cheapest wins.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class Value(Protocol):
    """Batched action and preparedness values over states of one compiled model.

    Optional: `native_q_max(task)` returns a `NativeQMax` for the task, or None where the value has no
    compiled form here; the compiled search (`planning.search.bellman_novelty`) then calls its `fn`
    instead of `q_max`, and its `v_ap` (where it has one) instead of `v_ap`. Either way the values must
    be the same: the search's choices do not depend on which is called."""

    gamma: float
    """The discount the value was made with; the search discounts its prefix costs by it."""

    def q_max(self, states: list, task) -> np.ndarray:
        """max_a Q(s, task, a) per state, as a float array of len(states)."""

    def v_ap(self, states: list) -> np.ndarray:
        """The preparedness value V_AP(s) per state, as a float array of len(states)."""


class NativeQMax(Protocol):
    """A compiled q_max for the compiled Bellman–Novelty search (`Value.native_q_max`)."""

    fn: object
    """A C function of type `bn_native_fn` (planning/search/_bn.c), `int fn(ctx, task, states, n, W, out)`:
    called at each flush with the task's index and the flush's n states (W packed words each), it
    writes their q_max into out[0..n) and returns 0; anything else makes the search raise ValueError
    (the value refused its input)."""

    ctx: object
    """The pointer passed to `fn` as its context."""

    model: object
    """The compiled model it was built for (optional): on any other model the search uses `q_max`."""

    def v_ap(self, states: list) -> np.ndarray:
        """Optional: V_AP per state, as the value's `v_ap` (the terminals are scored with it)."""


class ZeroValue:
    """The value that knows nothing: 0 everywhere. Under it every terminal ties, so the cheapest is chosen."""

    def __init__(self, gamma: float = 1.0):
        self.gamma = gamma

    @classmethod
    def load(cls, arg, model) -> "ZeroValue":
        """The value registry's hook: the zero value, discounting by the domain's [reward] gamma (default 1)."""
        if arg is not None:
            from planning.errors import DomainError

            raise DomainError("--value", f"zero takes no argument, not '{arg}'")
        return cls(float(model.config.get("reward", {}).get("gamma", 1.0)))

    def q_max(self, states: list, task) -> np.ndarray:
        return np.zeros(len(states))

    def v_ap(self, states: list) -> np.ndarray:
        return np.zeros(len(states))
