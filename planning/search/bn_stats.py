"""What a Bellman–Novelty search did and chose (`planning.search.bellman_novelty`), filled as it runs."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class BNStats:
    """Counts of the turns and their outcomes, the choice, and where the time went (seconds)."""

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
