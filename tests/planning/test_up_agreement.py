"""Our applicable actions and successors equal unified-planning's SequentialSimulator's."""

import pytest
from unified_planning.shortcuts import SequentialSimulator

from planning.external.simulator_bench import reachable_states
from planning.external.up_bridge import UPStates, action_name, up_problem


@pytest.mark.parametrize(
    "domain,layout,n",
    [
        ("domains/restaurant", "two-room", 500),
        ("domains/restaurant", "three-room", 500),
        ("domains/minimal", "grid", 60),
        ("domains/blockworld", "grid7x7", 200),
        ("domains/blockworld", "grid10x10", 200),
    ],
)
def test_random_walks_agree_with_unified_planning(domain, layout, n):
    from planning.domain.compiler import compile_domain

    m = compile_domain(domain, layout)
    states = reachable_states(m, n, seed=11)  # distinct states along random walks
    assert len(set(states)) >= n
    problem = up_problem(m)
    with SequentialSimulator(problem=problem) as sim:
        conv = UPStates(m, problem, sim)
        for s in states:
            up_state = conv.to_up(s)
            assert conv.from_up(up_state) == s
            theirs = {}
            for action, params in sim.get_applicable_actions(up_state):
                theirs[action_name(action, params)] = conv.from_up(sim.apply(up_state, action, params))
            ours = {m.actions[a]: t for a, t, _ in m.successors(s)}
            assert ours == theirs, m.describe(s)
