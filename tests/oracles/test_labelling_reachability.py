"""The labelling oracle's reachability check: task consumption and world resets make states reachable that
actions alone do not, and where the check cannot prove a state impossible it warns instead of refusing."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from oracles import labelling
from oracles.labelling import ReachablePairs, check_possible, reachable_states
from planning import cli
from planning.domain.compiler import compile_domain
from planning.heuristics.lmcut_pc import MutexPairs
from planning.search.optimal import uniform_cost_search

ROOT = Path(__file__).resolve().parents[2]
MUGS = str(ROOT / "tests" / "data" / "check" / "consumption")
DIRTY_AT_B = ["(robot-at desk_b)", "(hand-free)", "(at mug_0 desk_b)", "(dirty mug_0)"]


@pytest.fixture(scope="module")
def mugs():
    return compile_domain(MUGS, "office")


def label_cli(monkeypatch, capsys, *argv) -> tuple[int, str, str]:
    monkeypatch.setattr(sys, "argv", ["labelling", "--domain", MUGS, *argv])
    code = 0
    try:
        cli.run(labelling.main)
    except SystemExit as e:
        code = e.code
    out, err = capsys.readouterr()
    return code, out, err


def test_a_consumption_reached_state_is_labelled(mugs, monkeypatch, capsys, tmp_path):
    """Only serving coffee (a task's consumption) dirties the mug: the state it leaves, robot and dirty mug at
    desk_b, is reached by serve(desk_b) from the start. Actions alone never reach it (the old check refused
    it); the check that counts consumption accepts it, and it is labelled: serve(desk_a) = pick 1 + to the
    kitchen 4 + wash 2 + to desk_a 3 + place 1 = 11, serve(desk_b) = 1 + 4 + 2 + 4 + 1 = 12."""
    state = mugs.state_from_atoms(DIRTY_AT_B)
    serve_b = mugs.tasks.get("serve(desk_b)")
    s = mugs.init
    for a in uniform_cost_search(mugs, s, serve_b).plan:
        s = mugs.apply(s, a)
    assert serve_b.consume(s) == state  # reachable: the task's own consumption
    assert not MutexPairs(mugs, [mugs.init]).respects(state)  # what actions alone allow: refused
    assert ReachablePairs(mugs).violated(state) == []
    assert check_possible(mugs, state, "s") is None
    path = tmp_path / "dirty.json"
    path.write_text(json.dumps(DIRTY_AT_B))
    code, out, err = label_cli(monkeypatch, capsys, "--state", str(path), "--heuristic", "hmax")
    assert (code, err) == (0, "")
    assert "C_AP = 11.50 over 2 tasks" in out
    assert "serve(desk_a)" in out and "cost    11" in out and "cost    12" in out


def test_an_impossible_state_is_still_refused(mugs, monkeypatch, capsys, tmp_path):
    path = tmp_path / "two-places.json"
    path.write_text(json.dumps(["(robot-at desk_a)", "(robot-at desk_b)", "(hand-free)", "(at mug_0 desk_a)"]))
    code, out, err = label_cli(monkeypatch, capsys, "--state", str(path))
    assert code == 2 and out == ""
    assert err.strip() == (
        f"error: {path}: an impossible state: (robot-at desk_a) and (robot-at desk_b) never "
        "hold together in any state this layout reaches (from a world reset, by actions and "
        "task consumption)"
    )


def test_unsure_is_a_warning_not_a_refusal(mugs, monkeypatch, capsys, tmp_path):
    """No robot anywhere breaks no pair, but none of the 24 reachable states is it: a warning, then the label
    (every task unsolvable there, so C_AP is undefined: that error is the labeller's own). A pair analysis cut
    short proves nothing either: the robot in two places is then a warning too."""
    nowhere = mugs.state_from_atoms(["(hand-free)", "(at mug_0 desk_a)"])
    states, complete = reachable_states(mugs)
    assert complete and len(states) == 24 and nowhere not in states
    assert check_possible(mugs, nowhere, "s") == (
        "s: not reachable as far as I can tell: none of the 24 states reachable from the world resets by actions "
        "and task consumption; labelled as given"
    )
    two = mugs.state_from_atoms(["(robot-at desk_a)", "(robot-at desk_b)", "(hand-free)", "(at mug_0 desk_a)"])
    assert not ReachablePairs(mugs, max_rounds=0).complete
    assert check_possible(mugs, two, "s", max_rounds=0).startswith(
        "s: not reachable as far as I can tell: (robot-at desk_a) and (robot-at desk_b) seem never to hold together"
    )
    path = tmp_path / "nowhere.json"
    path.write_text(json.dumps(["(hand-free)", "(at mug_0 desk_a)"]))
    code, out, err = label_cli(monkeypatch, capsys, "--state", str(path))
    lines = err.strip().splitlines()
    assert (
        lines[0] == f"warning: {path}: not reachable as far as I can tell: none of the 24 states reachable "
        "from the world resets by actions and task consumption; labelled as given"
    )
    assert code == 2 and "cannot be completed from this state" in lines[1]


def test_every_enumerated_state_respects_the_pairs(mugs, two_room):
    """The pairs are invariants: no state reachable by actions, consumption and resets breaks one (the mugs
    domain's whole reachable set; the restaurant's first 3,000 states, its consumption and both reset entries
    included), and the restaurant's old pairs (actions only) are kept but one: fruit-bowl's consumption dirties
    a bowl that may hold water, so (dirty bowl_0) and (has-water bowl_0) can hold together."""
    for model, limit in ((mugs, 1000), (two_room, 3000)):
        pairs = ReachablePairs(model)
        assert pairs.complete
        states, _ = reachable_states(model, limit)
        assert all(not pairs.violated(s) for s in states)
    old = MutexPairs(two_room, [two_room.init] + [two_room.reset_state(k) for k in range(32)])
    new = ReachablePairs(two_room).matrix
    assert int(np.triu(new, 1).sum()) == len(old) - 1
    assert not (np.triu(new, 1) & ~np.triu(old.matrix, 1)).any()  # nothing new is called mutex
    freed = np.argwhere(np.triu(old.matrix, 1) & ~np.triu(new, 1))
    assert [(two_room.atoms[i], two_room.atoms[j]) for i, j in freed] == [
        (("dirty", "bowl_0"), ("has-water", "bowl_0"))
    ]


def test_reset_worlds_are_counted_exactly(two_room):
    """Both restaurant reset entries can dirty their object in one world: the bowl and the knife dirty together
    is a reset world, not an impossible state."""
    both = two_room.state_from_atoms(
        [f"({' '.join(a)})" for a in two_room.true_atoms(two_room.init)] + ["(dirty bowl_0)", "(dirty knife_0)"]
    )
    assert ReachablePairs(two_room).violated(both) == []
    assert check_possible(two_room, both, "s") is None
