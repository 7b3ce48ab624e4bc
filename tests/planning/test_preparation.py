"""A domain's [preparation] (`planning.world.preparation`): the restaurant's deliveries counted on hand-made plans
and on a committed results file, the same table on another domain (a copy of the minimal grid), and one-line
errors for a bad declaration, also through the domain checker."""

import shutil
import sys
from pathlib import Path

import pytest

from planning import cli
from planning.domain.compiler import compile_domain
from planning.errors import DomainError
from planning.world import domain_check
from planning.world.preparation import Preparation
from tests.conftest import MINIMAL

ROOT = Path(__file__).resolve().parents[2]


def test_the_restaurant_counts_water_deliveries_from_the_jar_and_the_fountain():
    model = compile_domain(ROOT / "domains/restaurant", "three-room")
    prep = Preparation.of(model)
    assert prep.action == "refill-water"
    fresh = sorted(model.actions[a] for a in prep.fresh)
    # every fill but the jar's own: filling the jar prepares, it delivers nothing
    assert fresh == [f"fill({o}, water_fountain, fountain)" for o in ("bowl_0", "cup_0", "cup_1")]
    assert len(prep.reuse) == 3 * 7  # a cup or the bowl, from the jar, at any of the 7 locations
    plan = [
        "pick(jar_0, pantry)",
        "move(pantry, fountain)",
        "fill(jar_0, water_fountain, fountain)",  # preparing
        "place(jar_0, fountain)",
        "move(fountain, countertop)",
        "pick(cup_0, countertop)",
        "move(countertop, fountain)",
        "refill-water(cup_0, jar_0, fountain)",  # from the jar
        "fill(cup_1, water_fountain, fountain)",  # from scratch (never mind the hand)
    ]
    assert prep.count(plan) == (1, 1)
    rows = [{"plan": plan}, {"plan": plan[:3], "completion_plan": plan[7:8]}, {"auto": True}]
    assert prep.share(rows) == (2 / 3, 3)
    assert prep.share([{"auto": True}]) == (None, 0)
    with pytest.raises(DomainError, match="r.json: action 'fly\\(cup_0\\)' is not a ground action"):
        prep.share([{"plan": ["fly(cup_0)"]}], "r.json")


def test_a_committed_guided_run_draws_its_water_from_the_jar_and_the_myopic_oracle_never_does():
    import json

    model = compile_domain(ROOT / "domains/restaurant", "three-room")
    prep = Preparation.of(model)
    guided = json.loads((ROOT / "results/rl-guided-anticipatory-three-room-seed0.json").read_text())
    myopic = json.loads((ROOT / "results/myopic-oracle-three-room.json").read_text())
    share, n = prep.share(guided["per_task"])
    assert share > 0.9 and n > 100
    assert prep.share(myopic["per_task"])[0] == 0.0


def grid(tmp_path, table: str):
    folder = tmp_path / "grid"
    shutil.copytree(ROOT / MINIMAL, folder)
    with open(folder / "domain.toml", "a") as f:
        f.write(table)
    return folder


def test_another_domain_declares_its_own_preparation(tmp_path):
    """On the grid: a place counts as a delivery from the preparation, a pick of anything but fruit from scratch."""
    folder = grid(
        tmp_path,
        '\n[preparation]\naction = "place"\ndeliveries = { reuse = ["place"], fresh = ["pick"], not_of = ["fruit"] }\n',
    )
    prep = Preparation.of(compile_domain(folder, "grid"))
    assert prep.action == "place" and prep.fresh == frozenset()  # the only thing is the apple, a fruit
    assert prep.count(["pick(apple, c)", "place(apple, a)", "move(a, x1y0)"]) == (1, 0)
    assert Preparation.of(compile_domain(ROOT / MINIMAL, "grid")) is None  # declared nowhere: no measure


@pytest.mark.parametrize(
    "table, reason",
    [
        ('action = "teleport"', "\\[preparation\\] action 'teleport' is not an action of the domain"),
        ('colour = "red"', "\\[preparation\\]: unknown key\\(s\\) colour"),
        ('deliveries = { reuse = ["place"] }', "\\[preparation.deliveries\\] names no fresh action"),
        ('deliveries = { reuse = ["place"], fresh = ["pick"], not_of = ["jar"] }', "no object of type 'jar'"),
        ('deliveries = { reuse = "place", fresh = ["pick"] }', "reuse is 'place', not a list of names"),
    ],
)
def test_a_bad_declaration_is_one_line_naming_domain_toml(tmp_path, monkeypatch, capsys, table, reason):
    folder = grid(tmp_path, f"\n[preparation]\n{table}\n")
    with pytest.raises(DomainError, match=reason) as e:
        Preparation.of(compile_domain(folder, "grid"))
    assert str(e.value).startswith(str(folder / "domain.toml"))
    monkeypatch.setattr(sys, "argv", ["check", str(folder), "--no-costs"])
    with pytest.raises(SystemExit) as code:
        cli.run(domain_check.main)
    err = capsys.readouterr().err
    assert code.value.code == 2 and "layout grid:" in err and "preparation" in err
