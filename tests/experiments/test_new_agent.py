"""A new agent is one module and one registry row: a throwaway planner, registered by a monkeypatched row,
is listed, built from its own flag, played by the evaluation command and named in its results file."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from experiments import registry

ROOT = Path(__file__).resolve().parents[2]

DETOUR = '''
from planning.domain.batched import BatchedModel
from planning.search.optimal import optimal_plan
from planning.world.agents import Planner, Reply


class DetourPlanner(Planner):
    """The optimal plan after --detour first moves (the first applicable each time): a throwaway agent."""

    name = "detour"

    @classmethod
    def options(cls, p):
        p.add_argument("--detour", type=int, default=0, help="moves made before the optimal plan (default: 0)")

    @classmethod
    def from_args(cls, args, model):
        return cls(model, args.detour)

    def __init__(self, model, detour=0):
        self.model, self.bm, self.detour = model, BatchedModel(model), detour
        self.config = {"detour": detour}
        self.run_name = f"detour-{detour}"

    def plan(self, state, task, upcoming):
        first = []
        for _ in range(self.detour):
            first.append(next(i for i in self.model.applicable(state) if self.model.actions[i].startswith("move(")))
            state = self.model.apply(state, first[-1])
        r = optimal_plan(self.bm, state, task)
        return Reply(None if r.plan is None else first + list(r.plan),
                     {"status": "solved" if r.plan is not None else "unsolvable"})
'''


@pytest.fixture
def detour(monkeypatch, tmp_path):
    (tmp_path / "detour_agent.py").write_text(DETOUR)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setitem(registry.AGENTS, "detour", ("detour_agent", "DetourPlanner"))
    yield
    sys.modules.pop("detour_agent", None)


def test_a_new_agent_is_one_module_and_one_row(detour, grid_folder, tmp_path, capsys):
    from experiments.evaluate import main

    assert "detour " in registry.describe()
    out = {}
    for name, extra in (("myopic-oracle", ["--planner", "internal"]), ("detour", []), ("detour-2", ["--detour", "2"])):
        agent = "myopic-oracle" if name == "myopic-oracle" else "detour"
        path = tmp_path / f"{name}.json"
        sys.argv = [
            "evaluate",
            "--agent",
            agent,
            "--domain",
            str(grid_folder),
            "--layout",
            "grid",
            *extra,
            "--sequences",
            "0-1",
            "--out",
            str(path),
            "--no-progress",
        ]
        main()
        out[name] = json.loads(path.read_text())
    costs = {k: [r["cost"] for r in d["per_task"]] for k, d in out.items()}
    assert costs["detour"] == costs["myopic-oracle"]  # the optimal plan, as the oracle's
    assert sum(costs["detour-2"]) > sum(costs["detour"])  # a detour first costs more
    assert out["detour-2"]["agent"] == "detour" and out["detour-2"]["config"] == {"detour": 2}
