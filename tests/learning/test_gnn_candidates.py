"""The focused candidate generator of the GNN's native selection (learning.gnn.candidates, domain.toml
[gnn.candidates]): its region, relevant objects, clause order and cap on hand-made restaurant states;
its table checked; the domain digest left alone; and a native selection that takes a preparation
exactly when the exact C_AP says it pays."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from learning.agents.gnn_native import GNNNativePlanner
from learning.gnn.candidates import FocusedCandidates, actions_along, parse_formula
from planning.domain.compiler import compile_domain
from planning.errors import DomainError

ROOT = Path(__file__).resolve().parents[2]

# a hand-made two-room state: the machine water used up, cup_0, bowl_0 and knife_0 dirty
BASE = [
    "(robot-at countertop)",
    "(hand-free)",
    "(at cup_0 countertop)",
    "(dirty cup_0)",
    "(at cup_1 dishwasher)",
    "(at water_fountain fountain)",
    "(at apple_0 countertop)",
    "(at bowl_0 countertop)",
    "(dirty bowl_0)",
    "(at knife_0 countertop)",
    "(dirty knife_0)",
    "(at jar_0 shelf)",
    "(at plate_0 servingtable)",
]


def walk(model, state, names):
    """The path of states and the plan of the named actions from `state`."""
    plan = [model.action(n) for n in names]
    path = [state]
    for a in plan:
        path.append(model.apply(path[-1], a))
    return path, plan


@pytest.fixture(scope="module")
def focused(two_room):
    return FocusedCandidates.from_model(two_room)


def test_region_is_the_path_plus_one_base_hop(two_room, three_room, focused):
    """Base hop 25 (the smallest move cost): from the countertop the coffee machine and the shelf are one hop,
    the dishwasher two; from the serving table nothing is (the fountain is 50 away); the pantry is in no one's."""
    assert focused.base_hop == 25 and focused.hops == 1 and focused.max_clauses == 10
    s = two_room.state_from_atoms(BASE)
    assert focused.region([s]) == {"countertop", "coffeemachine", "shelf"}
    path, _ = walk(two_room, s, ["move(countertop, servingtable)"])
    assert focused.region(path) == {"countertop", "coffeemachine", "shelf", "servingtable"}
    path, _ = walk(two_room, s, ["move(countertop, dishwasher)"])
    assert focused.region(path) == {"countertop", "coffeemachine", "shelf", "dishwasher"}
    three = FocusedCandidates.from_model(three_room)
    everywhere = ["countertop", "coffeemachine", "dishwasher", "shelf", "servingtable", "fountain"]
    path, _ = walk(three_room, three_room.init, [f"move({a}, {b})" for a, b in zip(everywhere, everywhere[1:])])
    assert three.region(path) == set(everywhere)  # the pantry, 875 away, is not
    assert three.region([three_room.state_from_atoms(["(robot-at pantry)", "(hand-free)"])]) == {"pantry"}


def test_relevant_objects(two_room, focused):
    """Those the plan names, those located in the region now (through containers), and the used-up machine water."""
    s = two_room.state_from_atoms(BASE)
    region = focused.region([s])
    assert focused.relevant(s, [], region) == {"cup_0", "apple_0", "bowl_0", "knife_0", "jar_0", "water_machine"}
    _, plan = walk(two_room, s, ["move(countertop, dishwasher)", "pick(cup_1, dishwasher)"])
    assert "cup_1" in focused.relevant(s, plan, region) and "plate_0" not in focused.relevant(s, plan, region)
    full = two_room.state_from_atoms(BASE + ["(at water_machine coffeemachine)"])
    assert "water_machine" in focused.relevant(full, [], region)  # at the coffee machine, in the region
    far = two_room.state_from_atoms(
        [
            "(robot-at servingtable)",
            "(hand-free)",
            "(at water_machine coffeemachine)",
            "(at bowl_0 servingtable)",
            "(in apple_0 bowl_0)",
            "(at jar_0 shelf)",
        ]
    )
    assert focused.relevant(far, [], focused.region([far])) == {"bowl_0", "apple_0"}  # the apple in the bowl
    empty = two_room.state_from_atoms(["(robot-at servingtable)", "(hand-free)", "(at jar_0 shelf)"])
    assert focused.relevant(empty, [], focused.region([empty])) == {"water_machine"}  # used up: nowhere


def test_clause_order_sorted_objects_families_in_order(two_room, focused):
    """Walking to the fountain: objects in sorted name order, within one the families in declaration order
    (clean, fill, jar to the coffee station, machine water); no cost sort (the jar's fill, 1,000 and more,
    comes before the knife's wash); cup_1 (at the dishwasher, not named) gives none."""
    s = two_room.state_from_atoms(BASE)
    path, plan = walk(two_room, s, ["move(countertop, fountain)"])
    assert focused.region(path) == {"countertop", "coffeemachine", "shelf", "fountain"}
    got = [(c.family, c.text) for c in focused.clauses(s, plan, path)]
    assert got == [
        ("clean", "(not (dirty bowl_0))"),
        ("clean", "(not (dirty cup_0))"),
        ("fill", "(has-water cup_0)"),
        ("fill", "(has-water jar_0)"),
        ("jar-to-coffee", "(at jar_0 coffeemachine)"),
        ("clean", "(not (dirty knife_0))"),
        ("machine-water", "(at water_machine coffeemachine)"),
    ]
    # without the fountain in the region no fill; a clause that holds already (the jar at the machine) is not proposed
    at_machine = two_room.state_from_atoms([a for a in BASE if "jar_0" not in a] + ["(at jar_0 coffeemachine)"])
    got = [c.text for c in focused.clauses(at_machine, [], [at_machine])]
    assert got == [
        "(not (dirty bowl_0))",
        "(not (dirty cup_0))",
        "(not (dirty knife_0))",
        "(at water_machine coffeemachine)",
    ]
    c = focused.clauses(s, plan, path)[4]
    assert c.pos == 1 << two_room.atom_index[("at", "jar_0", "coffeemachine")] and c.neg == 0
    assert actions_along(two_room, path) == plan


def test_the_cap_keeps_the_first_clauses(two_room):
    """The native selection plans the first max_clauses of the generator's order and counts all it proposed."""
    s = two_room.state_from_atoms(BASE)
    path, plan = walk(two_room, s, ["move(countertop, fountain)"])
    zero = lambda states: np.zeros(len(states))
    agent = GNNNativePlanner(two_room, "stub", estimate=zero)
    assert agent.max_clauses == 10 and agent.config["candidate_generator"]["kind"] == "focused"
    kept, proposed = agent.proposed(s, path, plan)
    assert proposed == 7 and len(kept) == 7
    agent = GNNNativePlanner(two_room, "stub", max_clauses=3, estimate=zero)
    kept, proposed = agent.proposed(s, path)  # the plan recovered from the path
    assert proposed == 7 and [c.name for c in kept] == [
        "(not (dirty bowl_0))",
        "(not (dirty cup_0))",
        "(has-water cup_0)",
    ]


def test_a_domain_without_the_table_keeps_the_clause_library(minimal):
    assert FocusedCandidates.from_model(minimal) is None
    agent = GNNNativePlanner(minimal, "stub", estimate=lambda states: np.zeros(len(states)))
    assert agent.config["candidate_generator"]["kind"] == "clause-library" and agent.max_clauses == 10


@pytest.mark.parametrize(
    "table, match",
    [
        ({"hop": 1}, "unknown key 'hop'"),
        ({"hops": -1, "clause": [{}]}, "hops is -1"),
        ({"clause": []}, "no \\[\\[gnn.candidates.clause\\]\\]"),
        ({"clause": [{"name": "x", "roles": {"?o": "cupp"}, "goal": "(dirty ?o)"}]}, "type 'cupp'"),
        ({"clause": [{"name": "x", "roles": {"?o": "cup"}, "goal": "(dirtyy ?o)"}]}, "predicate 'dirtyy'"),
        ({"clause": [{"name": "x", "roles": {"?o": "cup"}, "goal": "(dirty ?p)"}]}, "uses \\?p"),
        ({"clause": [{"name": "x", "roles": {"?o": "cup"}, "goal": "(or (dirty ?o))"}]}, "a goal is an atom"),
        ({"clause": [{"name": "x", "roles": {"?o": "cup"}, "goal": "(in-region ?o)"}]}, "predicate 'in-region'"),
        (
            {"clause": [{"name": "x", "roles": {"?o": "cup"}, "when": "(at ?o)", "goal": "(dirty ?o)"}]},
            "takes 2 arguments",
        ),
        ({"clause": [{"name": "x", "roles": {"?o": "cup"}, "goal": "(dirty ?o"}]}, "names only"),
    ],
)
def test_a_bad_table_is_one_line(two_room, table, match):
    with pytest.raises(DomainError, match=match):
        FocusedCandidates(two_room, table)


def test_formula_parser():
    assert parse_formula("(and (dirty ?o) (not (at ?o x)))") == (
        "and",
        ("atom", "dirty", ("?o",)),
        ("not", ("atom", "at", ("?o", "x"))),
    )
    with pytest.raises(ValueError, match="text after"):
        parse_formula("(dirty ?o) (dirty ?p)")


def test_the_table_is_a_tool_setting_left_out_of_the_digest(tmp_path):
    """The restaurant's digest is the same without [gnn] (committed results record it)."""
    from planning.domain.identity import SETTINGS_TABLES, identity

    assert "gnn" in SETTINGS_TABLES
    folder = tmp_path / "restaurant"
    shutil.copytree(ROOT / "domains/restaurant", folder, ignore=shutil.ignore_patterns("sequences"))
    text = (folder / "domain.toml").read_text()
    assert "[gnn.candidates]" in text
    (folder / "domain.toml").write_text(text[: text.index("[gnn.candidates]")])
    assert (
        identity(compile_domain(folder, "two-room"))["domain_sha256"]
        == identity(compile_domain(ROOT / "domains/restaurant", "two-room"))["domain_sha256"]
    )


PARK = """
[gnn.candidates]
hops = {hops}
[[gnn.candidates.clause]]
name = "park"
roles = {{ "?t" = "fruit", "?r" = "cell" }}
when = "(and (receptacle ?r) (in-region ?r) (not (at ?t ?r)))"
goal = "(at ?t ?r)"
"""


@pytest.mark.parametrize(
    "hops, deliver, chosen",
    [
        (3, "{ b = 0.8, a = 0.2 }", "(at apple b)"),  # B, 3 cells away, in the region: 4 + 1.2 < 2 + 4.8
        (3, "{ b = 0.2, a = 0.8 }", "myopic"),  # B rarely asked for: 4 + 4.8 > 2 + 1.2
        (1, "{ b = 0.8, a = 0.2 }", "myopic"),  # B out of the region: never proposed
    ],
)
def test_native_selection_takes_a_preparation_when_the_exact_c_ap_says_it_pays(tmp_path, hops, deliver, chosen):
    """The minimal grid with a [gnn.candidates] table: the robot at x1y0 holds the apple, task clear(c). The
    myopic plan puts it on A (one move and a place, 2); parking it on B costs 4. Scored with the exact C_AP
    (oracles.labelling) in place of the GNN, B is chosen exactly when the next delivery is mostly to B."""
    from oracles.labelling import Labeller

    folder = tmp_path / "grid"
    shutil.copytree(ROOT / "domains/minimal", folder)
    text = (folder / "domain.toml").read_text().replace("{ b = 0.8, a = 0.2 }", deliver)
    (folder / "domain.toml").write_text(text + PARK.format(hops=hops))
    model = compile_domain(folder, "grid")
    labeller = Labeller(model)
    exact = lambda states: np.array([labeller.label(s).c_ap for s in states])
    agent = GNNNativePlanner(model, "exact C_AP", estimate=exact)
    agent.start(model, None)
    state, task = model.state_from_atoms(["(robot-at x1y0)", "(holding apple)"]), model.tasks.get("clear(c)")
    r = agent.plan(state, task, [])
    assert r.info["chosen"] == chosen and r.info["c_myo"] == 2
    costs, hat = r.info["candidate_costs"], r.info["c_ap_hat"]
    names = ["myopic", "(at apple a)"] + ([] if hops == 1 else ["(at apple b)"])  # A: the myopic end again
    assert len(costs) == len(names) and r.info["in_region"] == len(names) - 1 and r.info["dropped"] == 0
    assert costs[1] == costs[0] and hat[1] == hat[0]
    if hops == 3:
        b = names.index("(at apple b)")
        assert costs[b] == 4 and (costs[b] + hat[b] < costs[0] + hat[0]) == (chosen != "myopic")
    end = state
    for a in r.plan:
        end = model.apply(end, a)
    assert ("at", "apple", "b" if chosen != "myopic" else "a") in model.true_atoms(end)


def test_the_candidate_cache_keys_on_the_domain_content_not_its_comments(tmp_path):
    """A comment edited in domain.toml keeps the cache; a changed task probability makes it a one-line error."""
    from learning.agents.gnn_native import CandidateCache

    folder = tmp_path / "minimal"
    shutil.copytree(Path(__file__).resolve().parents[2] / "domains" / "minimal", folder)
    cache, settings = tmp_path / "c.jsonl", {"max_clauses": 10}
    CandidateCache(compile_domain(folder, "grid"), cache, settings)
    toml = folder / "domain.toml"
    toml.write_text("# a comment that changes nothing\n" + toml.read_text())
    CandidateCache(compile_domain(folder, "grid"), cache, settings)
    with pytest.raises(DomainError, match="another domain or settings"):
        CandidateCache(compile_domain(folder, "grid"), cache, {"max_clauses": 5})
    text = toml.read_text()
    assert text.count("probability = 0.0") == text.count("probability = 1.0") == 1  # clear(c), deliver
    toml.write_text(
        text.replace("probability = 0.0", "probability = 0.25").replace("probability = 1.0", "probability = 0.75")
    )
    with pytest.raises(DomainError, match="another domain or settings"):
        CandidateCache(compile_domain(folder, "grid"), cache, settings)


def test_runs_in_parallel_share_the_candidate_cache_as_they_plan(tmp_path, minimal):
    """Two runs open one cache file: what one plans, the other finds on its next miss; a line still being
    written (no newline yet) is read once it is complete."""
    from learning.agents.gnn_native import CandidateCache

    path, settings = tmp_path / "c.jsonl", {"max_clauses": 10}
    a, b = CandidateCache(minimal, path, settings), CandidateCache(minimal, path, settings)
    task, plan = minimal.tasks[0], [0, 1]
    assert b.get(minimal.init, task) is None
    a.put(minimal.init, task, ["myopic"], [plan], 0, 1)
    assert b.get(minimal.init, task) == (["myopic"], [plan], 0, 1)
    other = minimal.tasks[1]
    line = json.dumps({"state": format(7, "x"), "task": other.name, "dropped": 2, "in_region": 3, "plans": []})
    with open(path, "a") as f:
        f.write(line[:10])
    assert b.get(7, other) is None
    with open(path, "a") as f:
        f.write(line[10:] + "\n")
    assert b.get(7, other) == ([], [], 2, 3)
    assert CandidateCache(minimal, path, settings).get(7, other) == ([], [], 2, 3)


def test_every_joint_heuristic_plans_the_same_candidate_costs_and_is_recorded(tmp_path, monkeypatch):
    """--joint-heuristic changes how the augmented candidates are searched, not what they cost: the grid's
    park-on-B choice is the same under each; the config and the default cache file name say which."""
    from learning.agents.gnn_native import JOINT_HEURISTICS
    from oracles.labelling import Labeller

    folder = tmp_path / "grid"
    shutil.copytree(ROOT / "domains/minimal", folder)
    (folder / "domain.toml").write_text((folder / "domain.toml").read_text() + PARK.format(hops=3))
    model = compile_domain(folder, "grid")
    labeller = Labeller(model)
    exact = lambda states: np.array([labeller.label(s).c_ap for s in states])
    state, task = model.state_from_atoms(["(robot-at x1y0)", "(holding apple)"]), model.tasks.get("clear(c)")
    monkeypatch.chdir(tmp_path)
    seen = {}
    for h in JOINT_HEURISTICS:
        agent = GNNNativePlanner(model, "exact C_AP", estimate=exact, candidates=None, joint_heuristic=h)
        agent.start(model, None)
        r = agent.plan(state, task, [])
        seen[h] = (r.info["chosen"], r.info["candidate_costs"])
        assert agent.config["joint_heuristic"] == h
        assert agent.config["candidates"].endswith("-c10.jsonl" if h == "pdb+lmcut" else f"-c10-{h}.jsonl")
    assert all(v == ("(at apple b)", [2, 2, 4]) for v in seen.values()), seen
    with pytest.raises(DomainError, match="--joint-heuristic"):
        GNNNativePlanner(model, "exact C_AP", estimate=exact, joint_heuristic="blind")


def test_a_corrupt_candidate_cache_line_is_one_line_error(tmp_path, minimal):
    from learning.agents.gnn_native import CandidateCache

    path, settings = tmp_path / "c.jsonl", {"max_clauses": 10}
    CandidateCache(minimal, path, settings)
    with open(path, "ab") as f:
        f.write(b"\xff\xfe not json\n")
    with pytest.raises(DomainError, match="line 2 is not a candidate entry"):
        CandidateCache(minimal, path, settings)
