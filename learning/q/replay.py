"""The replay memory of Algorithm 1: packed states, task and action indices, rewards and kinds in numpy.

A transition is (s, τ, a, r, s', kind): s and s' packed (W uint64 words each), τ
a task index, a a ground action (or AUTO), r in RL units, kind the bootstrap
rule (CONTINUE, COMPLETE, TERMINAL, below). Demonstrations live in
a second, never-overwritten memory; `mixed_batch` reserves a fixed share of
every minibatch for them (Appendix A.1, the protected demo fraction).
"""

from __future__ import annotations

import numpy as np

# Transition kinds in the replay buffer: how the target bootstraps (Algorithm 1).
CONTINUE = 0  # within the task, or the per-task timeout: bootstrap the same task (§4.1.3 a)
COMPLETE = 1  # the task completed: myopic y = r, anticipatory y = r + γ V_AP(s')
TERMINAL = 2  # the domain declares the episode over (e.g. the minimal example): y = r


class Replay:
    """A ring buffer of transitions."""

    def __init__(self, capacity: int, n_words: int):
        self.capacity, self.size, self.pos = capacity, 0, 0
        self.states = np.zeros((capacity, n_words), dtype=np.uint64)
        self.next_states = np.zeros((capacity, n_words), dtype=np.uint64)
        self.tasks = np.zeros(capacity, dtype=np.int32)
        self.actions = np.zeros(capacity, dtype=np.int64)
        self.rewards = np.zeros(capacity, dtype=np.float32)
        self.kinds = np.zeros(capacity, dtype=np.int8)
        self.writes = np.zeros(capacity, dtype=np.int64)  # per slot: how often written (for caches)

    def __len__(self) -> int:
        return self.size

    def add(self, s: np.ndarray, task: int, action: int, reward: float, s2: np.ndarray, kind: int) -> None:
        """Store one transition, overwriting the oldest when full."""
        i = self.pos
        self.states[i], self.next_states[i] = s, s2
        self.tasks[i], self.actions[i], self.rewards[i], self.kinds[i] = task, action, reward, kind
        self.writes[i] += 1
        self.pos = (i + 1) % self.capacity
        self.size = min(self.size + 1, self.capacity)

    def take(self, idx: np.ndarray) -> dict:
        """The transitions at the given slots, as arrays."""
        return {
            "states": self.states[idx],
            "tasks": self.tasks[idx],
            "actions": self.actions[idx],
            "rewards": self.rewards[idx],
            "next_states": self.next_states[idx],
            "kinds": self.kinds[idx],
        }

    def state_dict(self) -> dict:
        """Everything needed to rebuild the buffer (for resuming)."""
        n = self.size
        return {
            "capacity": self.capacity,
            "pos": self.pos,
            "size": n,
            **{k: v[:n].copy() for k, v in self.take(np.arange(n)).items()},
        }

    def load_state_dict(self, d: dict) -> None:
        """Restore what `state_dict` saved."""
        n = d["size"]
        self.states[:n], self.next_states[:n] = d["states"], d["next_states"]
        self.tasks[:n], self.actions[:n], self.rewards[:n], self.kinds[:n] = (
            d["tasks"],
            d["actions"],
            d["rewards"],
            d["kinds"],
        )
        self.size, self.pos = n, d["pos"]
        self.writes += 1


def mixed_batch(agent: Replay, demos: Replay, n: int, demo_fraction: float, rng) -> dict:
    """A minibatch of n: round(fraction * n) demonstrations (when there are any), the rest agent experience.

    Besides the transitions: "slots", where each came from (demo slot j is j, agent slot i is
    demos.capacity + i), and "writes", how often that slot had been written (what a per-slot
    cache checks to know the transition is still the one it saw)."""
    n_demo = int(round(demo_fraction * n)) if len(demos) else 0
    n_demo = max(n_demo, n - len(agent)) if len(demos) else 0  # early on, demos fill what the agent lacks
    parts = []
    if n_demo:
        idx = rng.integers(len(demos), size=n_demo)
        parts.append({**demos.take(idx), "slots": idx, "writes": demos.writes[idx]})
    if n - n_demo:
        idx = rng.integers(len(agent), size=n - n_demo)
        parts.append({**agent.take(idx), "slots": demos.capacity + idx, "writes": agent.writes[idx]})
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
