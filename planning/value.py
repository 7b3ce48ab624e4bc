"""The value protocol: what a search or a candidate scorer asks of a value (thesis §4.2, SPEC "Values").

A value is anything that, for a batch of states of one compiled model, gives

    q_max(states, task) -> (N,) array   max_a Q(s, τ, a): how well placed s is to finish
                                        the *current* task τ (the Bellman lane's key)
    v_ap(states)        -> (N,) array   V_AP(s) = E_τ'~P[max_a Q(s, τ', a)]: how well
                                        prepared s is for the *next* task (terminal score)

Larger is better for both. `states` is a list of the model's int states, `task`
a `Task` of its distribution. Implementations: the Q-network's value
(`learning.qnet.ValueFunction`), the GNN estimate as -C_AP, an exact value by
value iteration on small domains, and `ZeroValue` below, which makes the
Bellman–Novelty search myopic: every terminal ties on V_AP, so the cheapest wins.
"""
from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class Value(Protocol):
    """Batched action and preparedness values over states of one compiled model."""

    gamma: float
    """The discount the value was made with; the search discounts its prefix costs by it."""

    def q_max(self, states: list, task) -> np.ndarray:
        """max_a Q(s, task, a) per state, as a float array of len(states)."""

    def v_ap(self, states: list) -> np.ndarray:
        """The preparedness value V_AP(s) per state, as a float array of len(states)."""


class ZeroValue:
    """The value that knows nothing: 0 everywhere. Under it every terminal ties, so the cheapest is chosen."""

    def __init__(self, gamma: float = 1.0):
        self.gamma = gamma

    def q_max(self, states: list, task) -> np.ndarray:
        return np.zeros(len(states))

    def v_ap(self, states: list) -> np.ndarray:
        return np.zeros(len(states))
