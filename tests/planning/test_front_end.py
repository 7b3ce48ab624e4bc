"""The PDDL front end takes what Fast Downward takes, each construct on a small folder of its own
(tests/data/front_end/<name>): subtypes in a cost function, constants and task schemas naming objects, a type
and an action of one name, derived predicates, conditional effects with unit costs, per-layout overrides, a
classical domain wrapped as a one-task folder; what is refused is one line with file and line; the PDDL
writer's output is valid PDDL that compiles to the same model; Fast Downward (through the bridge) and our
planner agree, and Fast Downward's plans replay in our simulator (and under unified-planning) at its cost."""

import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
from unified_planning.shortcuts import SequentialSimulator

from planning import heuristics
from planning.domain.batched import BatchedModel
from planning.domain.compiler import compile_domain
from planning.errors import DomainError
from planning.external import fast_downward as fd
from planning.external.pddl_writer import domain_text, problem_goal_text, problem_text, task_goal_text
from planning.external.up_bridge import UPStates, action_name, up_names, up_problem
from planning.heuristics import choose
from planning.search.optimal import optimal_plan, uniform_cost_search
from planning.world.from_problem import wrap

DATA = Path(__file__).resolve().parents[1] / "data" / "front_end"
ROOT = Path(__file__).resolve().parents[2]
FOLDERS = [
    ("subtypes", "floor"),
    ("constants", "town"),
    ("type-action", "line"),
    ("conditional", "trip"),
    ("layouts", "big"),
    ("derived", "grid"),
]


def model_of(name: str, layout: str):
    return compile_domain(DATA / name, layout)


def pairs(model, n: int = 4, seed: int = 3):
    """(state, task) pairs: the start state and states along a random walk, each with every task."""
    states = [model.init] + model.random_walk_states(n - 1, seed, walk=12)[1:]
    return [(s, t) for s in states for t in model.tasks]


# ---- the constructs ----------------------------------------------------------------------------------
def test_a_subtype_in_a_cost_functions_arguments():
    """desk - location, corner-desk - desk, (move-cost ?from ?to - location) read for desks and corner desks."""
    m = model_of("subtypes", "floor")
    cost = dict(zip(m.actions, m.action_cost))
    assert cost["move(dock, corner_c)"] == 9 and cost["move(desk_b, corner_c)"] == 2
    assert cost["move(desk_a, desk_b)"] == 2 and cost["pick(sheet_0, dock)"] == 1
    # "all" over desks takes the corner desk (a subtype two levels down) too
    assert [t.name for t in m.tasks] == ["file(desk_a)", "file(desk_b)", "file(corner_c)"]
    # pick 1, dock -> desk_b 4, desk_b -> corner_c 2, file 1
    assert uniform_cost_search(m, m.init, m.tasks.get("file(corner_c)")).cost == 8


def test_constants_and_task_schemas_naming_the_problems_objects():
    m = model_of("constants", "town")
    assert m.source.domain_constants == ("dock",) and "dock" in m.objects and "b1" in m.objects
    post = m.tasks.get("post-b1(office1)")  # (at b1 ?p) and (robot-at dock): an object and a constant
    # office2 -> office1 -> dock 4, load 1, -> office1 2, unload 1, -> dock 2
    assert uniform_cost_search(m, m.init, post).cost == 10
    text = problem_text(m, m.init, task_goal_text(m, post))
    objects = text.split("(:objects")[1].split(")")[0]
    assert "dock" not in objects and "b1 - parcel" in objects  # the constant stays in the domain
    # town.pddl has no (= (total-cost) 0); the written problem has it once
    assert text.count("(= (total-cost) 0)") == 1 and "(:metric minimize (total-cost))" in text


def test_a_type_and_an_action_of_one_name():
    """charge: a type and an action (and a task); refill: a constant and an action. Ours reads them as they
    are; unified-planning gets them renamed, consistently, and its simulator agrees with ours."""
    m = model_of("type-action", "line")
    assert "charge(pack_1, middle)" in m.actions and "refill(pack_2)" in m.actions
    names = up_names(m)
    assert names.types == {"charge": "charge-type"} and names.objects == {"refill": "refill-object"}
    problem = up_problem(m)
    with SequentialSimulator(problem=problem) as sim:
        conv = UPStates(m, problem, sim)
        for s in m.random_walk_states(30, 4, walk=10):
            up_state = conv.to_up(s)
            theirs = {
                action_name(a, p, m): conv.from_up(sim.apply(up_state, a, p))
                for a, p in sim.get_applicable_actions(up_state)
            }
            assert theirs == {m.actions[a]: t for a, t, _ in m.successors(s)}


def test_conditional_effects_and_unit_costs_without_action_costs():
    m = model_of("conditional", "trip")
    assert not m.source.action_costs and set(m.action_cost) == {1}
    s = m.apply(m.apply(m.init, m.action("put-in(book, home)")), m.action("put-in(laptop, home)"))
    s = m.apply(s, m.action("move(home, office)"))  # the case carries both
    assert m.describe(s).splitlines()[1].strip() == "at: book office, laptop office"
    r = uniform_cost_search(m, m.init, m.tasks.get("bring(book, office)"))
    assert r.cost == len(r.plan) == 3  # put-in, move, take-out: a plan length
    text = problem_text(m, m.init, "(and)")
    assert "total-cost" not in text and "total-cost" not in domain_text(m)


def test_per_layout_overrides_of_tasks_resets_and_coordinates():
    """The big layout adds desk d3 to the task arguments, the resets and the coordinates; the small layout,
    whose problem has no d3, compiles as if the big one did not exist."""
    small, big = model_of("layouts", "small"), model_of("layouts", "big")
    assert [(t.name, t.probability) for t in small.tasks] == [("deliver(d1)", 0.5), ("deliver(d2)", 0.5)]
    assert [(t.name, t.probability) for t in big.tasks] == [
        ("deliver(d1)", 0.25),
        ("deliver(d2)", 0.25),
        ("deliver(d3)", 0.5),
    ]
    assert "d3" not in small.config["coordinates"] and big.config["coordinates"]["d3"] == [5, 0]
    assert big.config["coordinates"]["d1"] == [0, 0]  # the global ones are kept
    assert small.config["tasks"]["deliver"]["arguments"] == {"?d": ["d1", "d2"]}
    at = lambda m, seed: [a[1] for a in m.true_atoms(m.reset_state(seed)) if a[0] == "robot-at"]
    assert {at(small, k)[0] for k in range(20)} == {"d1", "d2"}
    assert {at(big, k)[0] for k in range(40)} == {"d1", "d3"}  # [[layouts.big.reset]] replaces [[reset]]
    assert big.locations == ["d1", "d2", "d3"] and small.locations == ["d1", "d2"]


def test_a_layout_override_of_the_wrong_shape_is_one_line(tmp_path):
    folder = tmp_path / "layouts"
    shutil.copytree(DATA / "layouts", folder)
    toml = folder / "domain.toml"
    toml.write_text(toml.read_text().replace("coordinates = { d3 = [5, 0] }", 'coordinates = "d3"'))
    with pytest.raises(DomainError, match=r"\[layouts.big.coordinates\] is 'd3', not a table"):
        compile_domain(folder, "big")


# ---- derived predicates ------------------------------------------------------------------------------
def test_derived_predicates_are_evaluated_in_every_simulator():
    m = model_of("derived", "grid")
    heads = [{m.atoms[r[2].bit_length() - 1][0] for r in stratum} for stratum in m.axioms.strata]
    assert heads == [{"occupied", "stored"}, {"free"}]  # (free ?c) reads (occupied ?c) negated
    assert m.describe(m.init).splitlines()[-1].strip() == "free: a1, a3, b2, b3"
    states = m.random_walk_states(150, 1, walk=15)
    for s in states:  # derived atoms always follow from the others
        assert m.derive(s) == s
    bm = BatchedModel(m)
    parent, action, child, _ = bm.successors(bm.pack(states))
    ours = sorted((i, a, t) for i, s in enumerate(states) for a, t, _ in m.successors(s))
    assert sorted(zip(parent.tolist(), action.tolist(), bm.unpack(child))) == ours
    # a task's consumption recomputes them too: box1 shipped, its cell free again
    store = m.tasks.get("store()")
    plan = uniform_cost_search(m, m.init, store).plan
    s = m.init
    for a in plan:
        s = m.apply(s, a)
    after = store.consume(s)
    cell = next(a[2] for a in m.true_atoms(s) if a[:2] == ("at", "box1"))
    assert ("free", cell) in m.true_atoms(after) and ("stored",) not in m.true_atoms(after)
    binding = next(o for o in store.bindings if o.applicable(s))
    assert bm.unpack(bm.apply_op(bm.pack([s]), binding))[0] == after


def test_derived_predicates_optimal_costs_equal_fast_downwards_and_replay_under_unified_planning():
    m = model_of("derived", "grid")
    bm = BatchedModel(m)
    problem = up_problem(m)  # derived atoms written as their definitions: unified-planning has none
    with SequentialSimulator(problem=problem) as sim:
        conv = UPStates(m, problem, sim)
        for state, task in pairs(m, 3):
            r = fd.solve(m, state, task, time_limit=60)
            assert r.status == fd.Status.SOLVED and r.optimal, (task.name, r.message)
            assert r.cost == fd.replay_cost(m, state, r.plan, task)
            for h in ("lmcut", "hmax", "blind"):
                assert optimal_plan(bm, state, task, heuristic=h).cost == r.cost, (task.name, h)
            assert uniform_cost_search(m, state, task).cost == r.cost
            end = conv.replay(state, r.plan)
            assert task.satisfied(end)


def test_heuristics_that_are_not_admissible_with_derived_predicates_refuse_by_name():
    m = model_of("derived", "grid")
    assert optimal_plan(BatchedModel(m), m.init, m.tasks.get("store()")).cost == 10  # default: LM-cut
    for name, search in (
        ("pdb", "task"),
        ("pdb", "window"),
        ("layered", "window"),
        ("lmcut-pc", "multi-goal"),
        ("lmcut", "multi-goal"),
    ):
        with pytest.raises(
            DomainError,
            match=f"'{name}' is not admissible with the derived predicates of "
            r"warehouse \(occupied, free, stored\)",
        ) as e:
            choose(name, m, search)
        assert "\n" not in str(e.value)
    assert heuristics.admissible_with_derived("task") == ["lmcut", "hmax", "blind"]


RECURSIVE = """(define (domain rooms)
  (:requirements :typing :derived-predicates :negative-preconditions)
  (:types room)
  (:predicates (in ?r - room) (door ?a ?b - room) (open ?a ?b - room) (reach ?r - room) (lit ?r - room))
  (:derived (reach ?r - room) (in ?r))
  (:derived (reach ?r - room) (exists (?s - room) (and (reach ?s) (open ?s ?r))))
  (:action open-door :parameters (?a ?b - room)
    :precondition (and (reach ?a) (door ?a ?b) (not (open ?a ?b)))
    :effect (and (open ?a ?b) (open ?b ?a)))
  (:action switch-on :parameters (?r - room) :precondition (reach ?r) :effect (lit ?r)))
"""


def folder_with(tmp_path, domain: str, problem: str, tasks: str, toml: str) -> Path:
    folder = tmp_path / "f"
    folder.mkdir()
    for name, text in (("domain.pddl", domain), ("p.pddl", problem), ("tasks.pddl", tasks), ("domain.toml", toml)):
        (folder / name).write_text(text)
    return folder


def test_recursive_derived_predicates_fast_downward_directly_and_unified_planning_refuses(tmp_path):
    problem = """(define (problem p) (:domain rooms) (:objects r1 r2 r3 r4 - room)
  (:init (in r1) (door r1 r2) (door r2 r3) (door r3 r4) (door r2 r4)) (:goal (and)))"""
    tasks = """(define (domain rooms-tasks) (:requirements :typing)
  (:action light :parameters (?r - room) :precondition (lit ?r) :effect (and)))"""
    toml = '[layouts.p]\n[tasks.light]\nprobability = 1.0\narguments = { "?r" = ["r3", "r4"] }\n'
    m = compile_domain(folder_with(tmp_path, RECURSIVE, problem, tasks, toml), "p")
    for task in m.tasks:
        r = fd.solve(m, m.init, task, time_limit=60)
        assert r.status == fd.Status.SOLVED and r.cost == len(r.plan) == 3  # two doors, the light
        assert uniform_cost_search(m, m.init, task).cost == r.cost
        assert optimal_plan(BatchedModel(m), m.init, task, heuristic="hmax").cost == r.cost
    with pytest.raises(DomainError, match="derived predicate reach is recursive"):
        up_problem(m)


def test_derived_predicates_that_are_not_stratified_or_set_by_an_effect_are_one_line(tmp_path):
    bad = RECURSIVE.replace(
        "(:derived (reach ?r - room) (in ?r))",
        "(:derived (reach ?r - room) (not (lit ?r)))\n  (:derived (lit ?r - room) (not (reach ?r)))",
    )
    bad = bad.replace("(:action switch-on :parameters (?r - room) :precondition (reach ?r) :effect (lit ?r))", "")
    problem = "(define (problem p) (:domain rooms) (:objects r1 - room) (:init (in r1)) (:goal (and)))"
    tasks = "(define (domain t) (:action go :parameters () :precondition (reach r1) :effect (and)))"
    toml = "[layouts.p]\n[tasks.go]\nprobability = 1.0\n"
    with pytest.raises(
        DomainError,
        match=r"domain.pddl:\d+: derived predicate \w+ depends negatively on itself "
        r"\(through \w+\): the axioms are not stratified",
    ):
        compile_domain(folder_with(tmp_path, bad, problem, tasks, toml), "p")
    (tmp_path / "f").rename(tmp_path / "g")
    with pytest.raises(DomainError, match="action switch-on changes derived predicate reach"):
        compile_domain(
            folder_with(tmp_path, RECURSIVE.replace(":effect (lit ?r)", ":effect (reach ?r)"), problem, tasks, toml),
            "p",
        )


# ---- what is refused ---------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "old,new,message",
    [
        (
            "(increase (total-cost) 2)))\n\n  (:action refill",
            "(increase (battery) 10) (increase (total-cost) 2)))\n\n  (:action refill",
            r"domain.pddl:23: numeric effect \(increase \(battery\) 10\) in action charge: "
            r"numeric fluents are not supported",
        ),
        (
            "(stored ?c refill))",
            "(stored ?c refill) (> (battery) 3))",
            r"domain.pddl:27: numeric condition \(> \(battery\) 3\) in action refill: numeric fluents are not supported",
        ),
        (
            "(and (robot-at refill) (not (full ?c))",
            "(and (robot-at (station ?c)) (not (full ?c))",
            r"domain.pddl:27: function term \(station \?c\) in action refill: object fluents are not supported",
        ),
        (
            "(:action refill",
            "(:durative-action refill",
            r"domain.pddl:25: durative action refill: durative actions are not supported",
        ),
        (
            "(increase (total-cost) 3)",
            "(increase (total-cost) (* 2 (battery)))",
            r"domain.pddl:28: cost expression .* in action refill: an action cost must be a number or a static function",
        ),
    ],
)
def test_what_is_refused_is_one_line_with_file_line_construct_and_action(tmp_path, old, new, message):
    folder = tmp_path / "type-action"
    shutil.copytree(DATA / "type-action", folder)
    path = folder / "domain.pddl"
    text = path.read_text().replace(
        "(:functions (total-cost) - number)", "(:functions (total-cost) - number (battery) - number)"
    )
    assert old in text
    path.write_text(text.replace(old, new))
    with pytest.raises(DomainError, match=message) as e:
        compile_domain(folder, "line")
    assert "\n" not in str(e.value)


def test_a_metric_other_than_total_cost_is_refused_with_its_line(tmp_path):
    folder = tmp_path / "type-action"
    shutil.copytree(DATA / "type-action", folder)
    path = folder / "line.pddl"
    path.write_text(path.read_text().replace("minimize (total-cost)", "maximize (total-cost)"))
    with pytest.raises(DomainError, match=r"line.pddl:9: metric .* only \(:metric minimize \(total-cost\)\)"):
        compile_domain(folder, "line")


# ---- the PDDL writer and Fast Downward ---------------------------------------------------------------
@pytest.mark.parametrize("name,layout", FOLDERS)
def test_the_written_domain_and_problem_compile_to_the_same_model(tmp_path, name, layout):
    """domain_text and problem_text are valid PDDL for every construct: written out and read back, the layout
    has the same atoms, ground actions, costs and successors."""
    m = model_of(name, layout)
    folder = tmp_path / name
    shutil.copytree(DATA / name, folder)
    (folder / "domain.pddl").write_text(domain_text(m))
    (folder / m.files["problem"].name).write_text(problem_text(m, m.init, problem_goal_text(m), layout))
    again = compile_domain(folder, layout)
    assert (again.atoms, again.actions, again.action_cost) == (m.atoms, m.actions, m.action_cost)
    assert again.init == m.init and [t.name for t in again.tasks] == [t.name for t in m.tasks]
    for s in m.random_walk_states(20, 2, walk=8):
        assert again.successors(s) == m.successors(s)


@pytest.mark.parametrize("name,layout", FOLDERS)
def test_fast_downward_through_the_bridge_agrees_and_its_plans_replay(name, layout):
    m = model_of(name, layout)
    for state, task in pairs(m, 2, seed=5):
        r = fd.solve(m, state, task, time_limit=60)
        assert r.status == fd.Status.SOLVED, (task.name, r.message)
        assert r.cost == fd.replay_cost(m, state, r.plan, task)
        assert uniform_cost_search(m, state, task).cost == r.cost, task.name


# ---- classical PDDL as written -----------------------------------------------------------------------
def test_a_classical_blocksworld_wrapped_as_a_one_task_folder(tmp_path):
    """No :action-costs, untyped, goal over the problem's objects: wrapped without edits, solved at the optimal
    plan length (8) by our planner and by Fast Downward."""
    out = wrap(DATA / "blocksworld" / "domain.pddl", DATA / "blocksworld" / "p4.pddl", tmp_path / "bw")
    assert sorted(p.name for p in out.iterdir()) == ["domain.pddl", "domain.toml", "p4.pddl", "sequences", "tasks.pddl"]
    assert (out / "domain.pddl").read_bytes() == (DATA / "blocksworld" / "domain.pddl").read_bytes()
    m = compile_domain(out, "p4")
    task = m.tasks.get("goal()")
    ours = optimal_plan(BatchedModel(m), m.init, task, heuristic="lmcut")
    assert ours.cost == len(ours.plan) == uniform_cost_search(m, m.init, task).cost == 8
    r = fd.solve(m, m.init, task, time_limit=60)
    assert r.status == fd.Status.SOLVED and r.cost == len(r.plan) == 8
    from planning.world.sequences import load

    assert [t.name for t in load(m)[0].tasks] == ["goal()"]


def test_from_problem_on_the_command_line_and_a_foreign_folder_refused(tmp_path):
    args = [
        sys.executable,
        "-m",
        "planning.world.from_problem",
        str(DATA / "visitall" / "domain.pddl"),
        str(DATA / "visitall" / "grid4.pddl"),
        "--out",
        str(tmp_path / "va"),
    ]
    r = subprocess.run(args, capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert r.returncode == 0 and "layout grid4, one task 'goal()'" in r.stdout, r.stderr
    again = subprocess.run(args, capture_output=True, text=True, cwd=ROOT, timeout=120)  # its own files: rewritten
    assert again.returncode == 0, again.stderr
    (tmp_path / "va" / "notes.txt").write_text("mine")
    refused = subprocess.run(args, capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert refused.returncode == 2 and refused.stderr.count("\n") == 1 and "holds other files" in refused.stderr


# ---- the exact search: tie-breaking, time limits, the reported fallback -----------------------------
def test_ties_broken_by_h_expand_far_fewer_states(tmp_path):
    """Visitall 4x4 with LM-cut: f is 15 along the whole optimal path; closing lower h first walks it."""
    m = compile_domain(
        wrap(DATA / "visitall" / "domain.pddl", DATA / "visitall" / "grid4.pddl", tmp_path / "v"), "grid4"
    )
    bm, task = BatchedModel(m), m.tasks.get("goal()")
    plain = optimal_plan(bm, m.init, task, heuristic="lmcut", tie_break=False)
    ties = optimal_plan(bm, m.init, task, heuristic="lmcut", tie_break=True)
    assert plain.cost == ties.cost == 15
    assert ties.expansions <= 20 < 500 < plain.expansions


def test_a_time_limit_is_honoured_within_a_second_inside_a_level(tmp_path):
    n = 6
    cells = [f"c{x}{y}" for y in range(n) for x in range(n)]
    links = [
        f"(connected c{x}{y} c{x + dx}{y + dy})"
        for y in range(n)
        for x in range(n)
        for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1))
        if 0 <= x + dx < n and 0 <= y + dy < n
    ]
    (tmp_path / "g6.pddl").write_text(
        f"(define (problem g6) (:domain grid-visit-all) (:objects {' '.join(cells)} - place)\n"
        f"  (:init (at-robot c00) (visited c00) {' '.join(links)})\n"
        f"  (:goal (and {' '.join(f'(visited {c})' for c in cells)})))\n"
    )
    m = compile_domain(wrap(DATA / "visitall" / "domain.pddl", tmp_path / "g6.pddl", tmp_path / "v6"), "g6")
    bm, task = BatchedModel(m), m.tasks.get("goal()")
    for h in ("blind", "lmcut"):
        optimal_plan(bm, m.init, task, heuristic=h, time_limit=0.01)  # tables built before the clock starts
        start = time.perf_counter()
        r = optimal_plan(bm, m.init, task, heuristic=h, time_limit=1.0)
        assert r.plan is None and not r.complete and time.perf_counter() - start < 2.0, h


def test_the_pattern_database_fallback_is_reported_once(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(heuristics, "_REPORTED", set())
    out = wrap(DATA / "blocksworld" / "domain.pddl", DATA / "blocksworld" / "p4.pddl", tmp_path / "bw")
    m = compile_domain(out, "p4")
    bm, task = BatchedModel(m), m.tasks.get("goal()")
    assert optimal_plan(bm, m.init, task).cost == optimal_plan(bm, m.init, task, heuristic="pdb").cost == 8
    err = capsys.readouterr().err
    assert err == (
        "note: heuristic 'pdb' needs the locations that rooms under [layouts.p4] in domain.toml list "
        "(domain blocksworld gives none): using lmcut instead\n"
    )


def test_a_level_cut_into_chunks_under_a_time_limit_is_searched_as_one(tmp_path, monkeypatch):
    """Under a time limit a level's successors are made in chunks and its children scored in chunks; the
    search is the same as without a limit: the same plan, cost and expansions."""
    import planning.search.cost_levels as cl

    m = compile_domain(
        wrap(DATA / "visitall" / "domain.pddl", DATA / "visitall" / "grid4.pddl", tmp_path / "v"), "grid4"
    )
    bm, task = BatchedModel(m), m.tasks.get("goal()")
    whole = {h: optimal_plan(bm, m.init, task, heuristic=h) for h in ("blind", "hmax")}
    monkeypatch.setattr(cl, "SUCCESSOR_CHUNK", 7)
    monkeypatch.setattr(cl, "H_CHUNK", 3)
    for h, r in whole.items():
        cut = optimal_plan(bm, m.init, task, heuristic=h, time_limit=600)
        assert (cut.plan, cut.cost, cut.expansions) == (r.plan, r.cost, r.expansions), h
