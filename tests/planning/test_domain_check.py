"""The domain checker (planning.world.domain_check): its summary on the restaurant, one error line (file and line)
on each of ten broken copies of the minimal domain, and warnings, not errors, for the silent defaults."""

import shutil
import sys
from pathlib import Path

import pytest

from planning import cli
from planning.domain.compiler import compile_domain
from planning.world import domain_check

ROOT = Path(__file__).resolve().parents[2]
DATA = Path("tests/data/check")  # relative, as a user types it (the tests run from the root)


def run_check(monkeypatch, capsys, *argv) -> tuple[int, list[str], list[str]]:
    """(exit status, stdout lines, stderr lines) of `python -m planning.world.domain_check ARGV`, in process."""
    monkeypatch.chdir(ROOT)
    monkeypatch.setattr(sys, "argv", ["check", *map(str, argv)])
    code = 0
    try:
        cli.run(domain_check.main)
    except SystemExit as e:
        code = e.code
    out, err = capsys.readouterr()
    return code, out.strip().splitlines(), err.strip().splitlines()


def test_summary_on_the_restaurant(monkeypatch, capsys):
    """Both layouts: their atoms, ground actions and task instances (the model's own counts, and the numbers),
    and the myopic cost of each task type from the start state; no problem."""
    code, out, err = run_check(monkeypatch, capsys, "domains/restaurant")
    assert code == 0 and err == []
    expect = {"two-room": (70, 152, 42), "three-room": (78, 181, 48)}
    for layout, (atoms, actions, tasks) in expect.items():
        model = compile_domain("domains/restaurant", layout)
        assert (model.n_atoms, model.n_actions, len(model.tasks)) == (atoms, actions, tasks)
        line = next(x for x in out if x.startswith(f"restaurant {layout}:"))
        assert f"{atoms} atoms, {actions} ground actions, {tasks} task instances of 6 types" in line
        assert "2 reset entries (4 worlds)" in line
    assert "2 rooms (6 locations)" in out[0] and "3 rooms (7 locations)" in out[2]
    # serve-water from the start: walk to the shelf, the cup to the fountain, fill, to the table (thesis 1,475)
    assert out[1].startswith(
        "  myopic cost from the start state: serve-water 1,475; make-coffee 650; "
        "wash 0 (2 instances); clear 300; fruit-bowl 700; pick-place 0–600"
    )
    assert "pick-place 0–1,950" in out[3]
    assert out[-1] == "domains/restaurant: ok: 0 errors, 0 warnings"


def test_summary_object(monkeypatch):
    """The Checker's figures are the compiled model's."""
    monkeypatch.chdir(ROOT)
    c = domain_check.Checker("domains/minimal").run()
    model = compile_domain("domains/minimal", "grid")
    (s,) = c.summaries
    assert (s.atoms, s.actions, s.tasks, s.types) == (model.n_atoms, model.n_actions, len(model.tasks), 2)
    assert (s.resets, s.worlds, s.rooms, s.locations) == (1, 25, 1, 25)
    assert {t: [c for _, _, c in inst] for t, inst in s.costs.items()} == {"clear": [10], "deliver": [10, 10]}
    assert c.problems == []


BROKEN = [  # folder under tests/data/check, the file and line the error names, what it says
    ("probabilities", "domain.toml", 52, "task type probabilities sum to 0.9, not 1"),
    ("unknown-object", "domain.toml", 58, "task deliver: unknown object 'z' for ?r"),
    ("no-schema", "domain.toml", 60, "task 'fetch' has no schema in tasks.pddl"),
    ("unsolvable", "tasks.pddl", 5, "task clear(c) cannot be completed from the start state of layout grid"),
    ("reset-object", "domain.toml", 49, "unknown object 'attic' in (robot-at attic)"),
    ("heads", "domain.toml", 61, "[heads] move: '?dest' is not a parameter"),
    ("search", "domain.toml", 80, "[search] beta is 0.5, not a number of at least 1"),
    ("rooms", "domain.toml", 18, "room grid of layout grid lists 'x9y9', which is not an object of its problem"),
    ("syntax", "domain.pddl", 22, "cannot parse PDDL domain: line 22:16 extraneous input '('"),
    ("first-task", "domain.toml", 12, "[stream] first_task 'clear(z)' is not a task instance of layout grid"),
]


@pytest.mark.parametrize("name, file, line, message", BROKEN, ids=[b[0] for b in BROKEN])
def test_a_broken_folder_is_one_error_line(monkeypatch, capsys, name, file, line, message):
    folder = DATA / name
    code, out, err = run_check(monkeypatch, capsys, folder)
    assert code == 2
    assert len(err) == 1, err
    assert err[0].startswith(f"error: {folder / file}:{line}: {message}"), err[0]
    assert out[-1] == f"{folder}: not usable as it is: 1 error, 0 warnings"


def test_the_consumption_domain_is_clean(monkeypatch, capsys):
    code, out, err = run_check(monkeypatch, capsys, DATA / "consumption")
    assert (code, err) == (0, [])
    assert out[0] == (
        "mugs office: 9 atoms, 13 ground actions, 2 task instances of 1 type, 0 reset entries "
        "(1 world), 2 rooms (3 locations)"
    )
    assert out[1] == "  myopic cost from the start state: serve 5–6, mean 6 over P (2 instances)"


def copy_minimal(tmp_path, edit) -> Path:
    folder = tmp_path / "minimal"
    shutil.copytree(ROOT / "domains" / "minimal", folder)
    toml = folder / "domain.toml"
    toml.write_text(edit(toml.read_text()))
    return folder


def test_silent_defaults_are_warnings(monkeypatch, capsys, tmp_path):
    """No [search], no [reward] cost_scale, a location left out of the rooms: three warnings, exit 0."""

    def edit(text):
        text = text.split("[search]")[0]  # no [search]
        text = text.replace("cost_scale = 1            # PDDL cost units per RL reward unit\n", "")
        return text.replace('"x3y4", "x4y4"] }', '"x3y4"] }')  # x4y4 in no room

    folder = copy_minimal(tmp_path, edit)
    code, out, err = run_check(monkeypatch, capsys, folder)
    assert code == 0
    assert len(err) == 3 and all(x.startswith(f"warning: {folder}/domain.toml") for x in err), err
    text = "\n".join(err)
    assert "no [search]: rl-guided takes beta = 1.0 (it then plays exactly the myopic plan)" in text
    assert "no [reward] cost_scale: the learners take 1 PDDL cost unit per reward unit" in text
    assert "1 location of layout grid in no room (x4y4)" in text
    assert out[-1] == f"{folder}: ok: 0 errors, 3 warnings"


def test_search_per_layout_and_unknown_keys(monkeypatch, tmp_path):
    """A per-layout [search] value without the layout is an error; unknown tables and keys are warnings."""
    folder = copy_minimal(
        tmp_path,
        lambda t: t.replace("beta = 3.0", "beta = { other = 3.0 }").replace(
            "[stream]", "[extras]\nx = 1\n\n[stream]\nmax_action = 64"
        ),
    )
    monkeypatch.chdir(ROOT)
    c = domain_check.Checker(folder, costs=False).run()
    assert [p.message for p in c.errors] == ["[search] beta has no entry for layout 'grid'"]
    warnings = [p.message for p in c.warnings]
    assert any(w.startswith("unknown table [extras]") for w in warnings)
    assert any(w.startswith("[stream] has unknown key 'max_action'") for w in warnings)
    assert "[search] beta names 'other', which is not a layout" in warnings


def test_unknown_layout_is_one_line(monkeypatch, capsys):
    code, out, err = run_check(monkeypatch, capsys, "domains/minimal", "--layout", "attic")
    assert code == 2 and err == ["error: domains/minimal/domain.toml: unknown layout 'attic' (known: grid)"]


def test_the_tools_say_where_they_take_a_silent_default(capsys, tmp_path):
    """Where the defaults are read: rl-guided without [search] beta (β = 1.0: exactly the myopic plan) and the
    reward without [reward] cost_scale (1): one warning line each on stderr, once however often they are read;
    an explicit --beta says nothing."""
    from learning import reward
    from learning.agents import guided
    from planning.domain.compiler import compile_source
    from planning.domain.folder import read_domain

    folder = copy_minimal(
        tmp_path,
        lambda t: t.split("[search]")[0].replace(
            "cost_scale = 1            # PDDL cost units per RL reward unit\n", ""
        ),
    )
    model = compile_source(read_domain(folder, "grid"))
    capsys.readouterr()
    for _ in range(2):
        agent = guided.ValueGuidedPlanner(model, "zero")
        assert reward.cost_scale(model) == 1.0
    assert agent.beta == 1.0
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"warning: {folder}/domain.toml: no [search] beta for layout grid: beta = 1.0, so the "
        "value-guided search plays exactly the myopic plan (set [search] beta, or pass --beta)",
        f"warning: {folder}/domain.toml: no [reward] cost_scale: 1 PDDL cost unit per reward unit "
        "(the rewards are -cost + R_goal; set [reward] cost_scale to scale them)",
    ]
    guided.ValueGuidedPlanner(model, "zero", beta=2.0)
    reward.cost_scale(compile_domain("domains/minimal", "grid"))
    assert capsys.readouterr().err == ""


def test_per_layout_overrides_are_checked_as_the_layout_reads_them(monkeypatch, tmp_path):
    """[layouts.grid.tasks.deliver] narrows deliver to b for the grid: no warning, two task instances."""
    folder = copy_minimal(
        tmp_path,
        lambda t: t.replace(
            "\n[coordinates]", '\n[layouts.grid.tasks.deliver]\narguments = { "?r" = ["b"] }\n\n[coordinates]', 1
        ),
    )
    monkeypatch.chdir(ROOT)
    c = domain_check.Checker(folder).run()
    assert c.problems == []
    (s,) = c.summaries
    assert s.tasks == 2 and {t: [n for n, _, _ in inst] for t, inst in s.costs.items()} == {
        "clear": ["clear(c)"],
        "deliver": ["deliver(b)"],
    }
