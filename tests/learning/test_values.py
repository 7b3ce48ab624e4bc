"""The value registry (learning.values): every kind loads by name, a new kind is one module and one row, and the
guided agents, value_rank and bench_bn take any of them through --value."""

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from experiments.registry import agent_class, agent_options, build
from learning import values
from learning.values.exact import ExactValue
from planning.errors import DomainError
from planning.value import Value, ZeroValue
from planning.world.runner import play_sequence
from planning.world.sequences import Sequence

ROOT = Path(__file__).resolve().parents[2]


def guided(name, argv, model):
    """The agent experiments.evaluate builds from `--agent name argv`."""
    cls = agent_class(name)
    p = argparse.ArgumentParser()
    cls.options(p)
    return build(cls, agent_options(cls, p.parse_args(argv)), model)


def test_names_parse_to_a_kind_and_its_argument(checkpoint, gnn):
    assert values.parse("gnn:x.pt") == ("gnn", "x.pt")
    assert values.parse("exact") == ("exact", None) and values.parse("exact:myopic") == ("exact", "myopic")
    assert values.parse("x.pt", "q-network") == ("q-network", "x.pt")
    assert values.parse(gnn) == ("gnn", gnn) and values.parse(checkpoint) == ("q-network", checkpoint)
    assert values.parse("q-network:c:/x.pt") == ("q-network", "c:/x.pt")
    assert [line.split()[0] for line in values.describe().splitlines()] == list(values.VALUES)
    with pytest.raises(DomainError, match="unknown value kind 'nope'"):
        values.value_class("nope")
    with pytest.raises(DomainError, match="zero takes no argument"):
        values.load_value("zero:1", None)


def test_every_row_loads_a_value_of_the_protocol(minimal, checkpoint, gnn):
    names = {"q-network": f"q-network:{checkpoint}", "gnn": f"gnn:{gnn}", "exact": "exact", "zero": "zero"}
    assert set(names) == set(values.VALUES)
    s = [minimal.init]
    for kind, name in names.items():
        v = values.load_value(name, minimal)
        assert isinstance(v, Value) and type(v) is values.value_class(kind), kind
        assert v.q_max(s, minimal.tasks.get("clear(c)")).shape == v.v_ap(s).shape == (1,)
    zero = values.load_value("zero", minimal)
    assert isinstance(zero, ZeroValue) and zero.gamma == 0.99  # the grid's [reward] gamma
    exact, myopic = values.load_value("exact", minimal), values.load_value("exact:myopic", minimal)
    assert (exact.horizon, myopic.horizon) == ("anticipatory", "myopic")
    assert exact.v_ap(s)[0] == ExactValue(minimal).v_ap(s)[0]
    assert values.record("exact:myopic") == {"value": "exact (learning.values.exact)", "horizon": "myopic"}
    assert values.record("zero") == {"value": "zero"}
    with pytest.raises(DomainError, match="q-network needs a checkpoint"):
        values.load_value("q-network", minimal)


def test_a_short_form_and_its_value_name_make_the_same_run(minimal, checkpoint, gnn):
    """--checkpoint PATH is --value q-network:PATH, --model PATH is --value gnn:PATH: same config, same name."""
    for name, short, kind, path, stem in (
        ("rl-guided", "--checkpoint", "q-network", checkpoint, "anticipatory-grid"),
        ("gnn-guided", "--model", "gnn", gnn, "grid"),
    ):
        a = guided(name, [short, path, "--budget", "50"], minimal)
        b = guided(name, ["--value", f"{kind}:{path}", "--budget", "50"], minimal)
        assert (a.config, a.run_name) == (b.config, b.run_name)
        assert a.run_name == f"{name}-{stem}-seed0-beta3-budget50-depth20"
        assert a.config["reference"] == {
            "planner": "internal",
            "time_limit": 60.0,
            "search": "astar(pdb) by f-levels",
            "note": "exact optimal: C_myo is the true myopic cost (the authors' was LAMA)",
        }
    rl = guided("rl-guided", ["--checkpoint", checkpoint], minimal)
    assert list(rl.config) == ["checkpoint", "step", "horizon", "gamma", "beta", "budget", "depth_cap", "reference"]
    assert rl.run_name == "rl-guided-anticipatory-grid-seed0"
    other = guided("gnn-guided", ["--value", f"q-network:{checkpoint}"], minimal)
    assert (
        other.run_name == "gnn-guided-q-network-rl-anticipatory-grid-seed0" and other.config["checkpoint"] == checkpoint
    )
    assert guided("rl-guided", ["--value", "exact:myopic"], minimal).run_name == "rl-guided-exact-myopic"


TILT = '''
import numpy as np


class TiltValue:
    """Prefers the states with the apple on one cell (the argument): V_AP 1 there, 0 elsewhere."""

    loaded = []

    def __init__(self, bit):
        self.bit, self.gamma = bit, 1.0

    @classmethod
    def load(cls, cell, model):
        cls.loaded.append(cell)
        return cls(1 << model.atom_index[("at", "apple", cell)])

    def q_max(self, states, task):
        return np.zeros(len(states))

    def v_ap(self, states):
        return np.array([float(bool(s & self.bit)) for s in states])
'''


@pytest.fixture
def tilt(monkeypatch, tmp_path):
    """A throwaway value kind: its module on the path, its row in the registry."""
    (tmp_path / "tilt_value.py").write_text(TILT)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setitem(values.VALUES, "tilt", ("tilt_value", "TiltValue", "the apple on one cell"))
    yield
    sys.modules.pop("tilt_value", None)


def test_a_new_value_kind_is_one_module_and_one_row(minimal, tilt):
    """Clearing C parks the apple on A or B at the same cost from these resets: tilt:b parks it on B, so
    delivering to B is then free and to A costs the walk; the zero value plays the reference plan, which
    parks it on A, as tilt:a does."""
    clear, to_a, to_b = (minimal.tasks.get(t) for t in ("clear(c)", "deliver(a)", "deliver(b)"))
    costs = {}
    for name in ("tilt:a", "tilt:b", "zero"):
        agent = guided("rl-guided", ["--value", name], minimal)
        costs[name] = [
            [r["cost"] for r in play_sequence(minimal, agent, Sequence(0, reset, [clear, to]))]
            for reset in (0, 1)
            for to in (to_a, to_b)
        ]
    import tilt_value

    assert tilt_value.TiltValue.loaded == ["a", "b"]
    assert costs == {
        "tilt:a": [[11, 0], [11, 6], [10, 0], [10, 6]],
        "tilt:b": [[11, 6], [11, 0], [10, 6], [10, 0]],
        "zero": [[11, 0], [11, 6], [10, 0], [10, 6]],
    }
    agent = guided("rl-guided", ["--value", "tilt:b"], minimal)
    assert agent.run_name == "rl-guided-tilt-b" and agent.config["value"] == "tilt:b"


def test_evaluate_plays_a_new_value_kind_and_exact_by_name(grid_folder, tilt, tmp_path, capsys):
    from experiments.evaluate import main

    out = {}
    for name in ("tilt:b", "exact", "zero"):
        path = tmp_path / f"{name.replace(':', '-')}.json"
        sys.argv = [
            "evaluate",
            "--agent",
            "rl-guided",
            "--domain",
            str(grid_folder),
            "--layout",
            "grid",
            "--value",
            name,
            "--sequences",
            "0-1",
            "--out",
            str(path),
            "--no-progress",
        ]
        main()
        out[name] = json.loads(path.read_text())
    assert out["tilt:b"]["config"]["value"] == "tilt:b"
    assert out["exact"]["config"]["horizon"] == "anticipatory"
    assert out["zero"]["config"]["value"] == "zero" and out["tilt:b"]["agent"] == "rl-guided"
    assert {k: [r["cost"] for r in d["per_task"]] for k, d in out.items()} == {
        k: [12, 0, 0, 0, 12, 0, 0, 6] for k in out
    }


def test_the_reference_is_any_registered_planner(minimal):
    """--reference-agent names the reference planner and its options; the default is today's myopic oracle."""
    from oracles.clairvoyant import ClairvoyantOracle

    seq = Sequence(0, 1, [minimal.tasks.get("clear(c)"), minimal.tasks.get("deliver(b)")])
    default = guided("rl-guided", ["--value", "exact"], minimal)
    named = guided("rl-guided", ["--value", "exact", "--reference-agent", "myopic-oracle"], minimal)
    assert (named.config, named.run_name) == (default.config, default.run_name)
    untimed = lambda rows: [{k: v for k, v in r.items() if not k.endswith("seconds")} for r in rows]
    assert untimed(play_sequence(minimal, named, seq)) == untimed(play_sequence(minimal, default, seq))
    fd = guided(
        "rl-guided", ["--value", "exact", "--reference-agent", "myopic-oracle --planner fast-downward"], minimal
    )
    assert fd.run_name == "rl-guided-exact-fast-downward" and fd.config["reference"]["time_limit"] == 60.0
    k2 = guided("rl-guided", ["--value", "exact", "--reference-agent", "clairvoyant --K 2"], minimal)
    assert isinstance(k2.reference, ClairvoyantOracle) and k2.reference.time_limit == 60.0
    assert (
        k2.config["reference"]["agent"] == "clairvoyant-2" and k2.run_name == f"rl-guided-exact-{k2.reference.run_name}"
    )
    rows = play_sequence(minimal, k2, seq)
    assert [r["success"] for r in rows] == [True, True]
    with pytest.raises(DomainError, match="random is not a planner"):
        guided("rl-guided", ["--value", "exact", "--reference-agent", "random"], minimal)
    cls = agent_class("rl-guided")
    with pytest.raises(DomainError, match="built by the agent registry"):
        cls.from_args(agent_options(cls, value="exact", reference_agent="clairvoyant"), minimal)


def _exactly_labelled(minimal, data: Path) -> Path:
    """A learning.gnn_dataset-like folder of the minimal grid's random-walk states labelled with C_AP = -100 V_AP
    of the exact value (the ranking `exact` gets right, Spearman 1)."""
    from planning.domain.grounding import atom_text

    exact = ExactValue(minimal)
    states = list(dict.fromkeys(minimal.random_walk_states(60, seed=0)))
    data.mkdir()
    (data / "meta.json").write_text(
        json.dumps(
            {
                "domain": minimal.name,
                "layout": "grid",
                "n": len(states),
                "c_ap": (-100 * exact.v_ap(states)).tolist(),
                "atoms": [[atom_text(k) for k in minimal.true_atoms(s)] for s in states],
            }
        )
    )
    return data


def test_value_rank_names_its_file_after_the_domain_and_the_domain_report_shows_it(minimal, tmp_path, monkeypatch):
    """Another domain's ranking is results/<domain>-value-rank-<data>.json (the restaurant's report reads
    value-rank-*.json), and that domain's report (experiments.report.domain) tables it; without one it says
    how to make it."""
    from experiments.report.domain import rankings
    from learning.values import rank as value_rank

    domain = str(Path("domains/minimal").resolve())
    data = _exactly_labelled(minimal, tmp_path / "walk")
    monkeypatch.chdir(tmp_path)
    (tmp_path / "results").mkdir()
    assert rankings(minimal.name)[0].startswith("Not measured yet")
    monkeypatch.setattr(sys, "argv", ["rank", "--domain", domain, "--data", str(data), "--value", "exact"])
    value_rank.main()
    written = [f.name for f in (tmp_path / "results").iterdir()]
    assert written == [f"{minimal.name}-value-rank-walk.json"] and minimal.name != "restaurant"
    lines = rankings(minimal.name)
    row = next(line for line in lines if written[0] in line)
    assert "| grid | `exact` |" in row and "| 1.000 | 1.000 | 100.0% |" in row
    c = -100 * ExactValue(minimal).v_ap(list(dict.fromkeys(minimal.random_walk_states(60, seed=0))))
    spread = json.loads((tmp_path / "results" / written[0]).read_text())["c_ap"]
    assert spread == pytest.approx({"mean": c.mean(), "std": c.std(), "min": c.min(), "max": c.max()}, abs=0.051)
    assert any(line.startswith(f"- `{written[0]}`: the states' exact C_AP, mean ") for line in lines)


def test_value_rank_and_bench_bn_take_a_value_by_name(minimal, tmp_path, monkeypatch):
    """value_rank scores `exact` against labels made from its own V_AP (a perfect ranking); bench_bn
    runs the search on it along a seeded stream and records its kind."""
    from learning.agents import bench_bn
    from learning.values import rank as value_rank

    data = _exactly_labelled(minimal, tmp_path / "data")
    row = value_rank.rank(["exact"], str(data), "domains/minimal")["values"][0]
    assert row["value"] == "exact" and row["kind"] == "ExactValue"
    assert row["all"]["spearman"] == 1.0 and row["all"]["slope_rl_per_pddl"] == pytest.approx(0.01)
    out = tmp_path / "bench.json"
    monkeypatch.setattr(
        sys,
        "argv",
        [
            "bench_bn",
            "--domain",
            "domains/minimal",
            "--layout",
            "grid",
            "--value",
            "exact",
            "--stream",
            "--seed",
            "0",
            "--tasks",
            "6",
            "--budget",
            "100",
            "--quiet",
            "--out",
            str(out),
        ],
    )
    bench_bn.main()
    r = json.loads(out.read_text())
    assert (r["value"], r["checkpoint"], r["same_plans"]) == ("exact", None, r["searched_tasks"])
    assert r["searched_tasks"] > 0


class _ExactOneTask:
    """V_AP = -C_AP / cost_scale, labelled exactly: the value that credits every atom its one-task saving."""

    def __init__(self, model):
        from oracles.labelling import Labeller

        self.gamma, self.model, self.labeller, self.labels = 1.0, model, Labeller(model), {}

    def label(self, state):
        """The labelling oracle's label of a state, labelled once (a search asks again for the states it meets)."""
        if state not in self.labels:
            self.labels[state] = self.labeller.label(state)
        return self.labels[state]

    def q_max(self, states, task):
        return self.v_ap(states)

    def v_ap(self, states):
        return np.array([-self.label(s).c_ap / self.model.cost_scale for s in states])


def _walk_dataset(model, folder, n):
    from planning.domain.grounding import atom_text

    states = list(dict.fromkeys(model.random_walk_states(n, seed=1)))
    folder.mkdir()
    meta = {
        "domain": model.name,
        "layout": model.layout,
        "n": len(states),
        "c_ap": [0.0] * len(states),
        "atoms": [[atom_text(k) for k in model.true_atoms(s)] for s in states],
    }
    (folder / "meta.json").write_text(json.dumps(meta))
    return states


def test_value_credit_of_an_atom_against_its_exact_saving(two_room, minimal, tmp_path):
    """--credit: a value that is -C_AP credits the filled jar exactly its saving, the zero value nothing; on
    the grid every robot position excludes the others, so no state can take a second one (one-line error)."""
    from learning.values.rank import credit
    from planning.value import ZeroValue

    _walk_dataset(two_room, tmp_path / "two-room", 12)
    c = credit(
        [_ExactOneTask(two_room), ZeroValue()], str(tmp_path / "two-room"), "domains/restaurant", "has-water  jar_0", 6
    )
    assert c["atom"] == "(has-water jar_0)" and c["pairs"] == 6
    exact, zero = c["values"]
    assert exact["credit_mean"] == pytest.approx(c["exact_saving"]["mean"], abs=0.01)
    assert c["exact_saving"]["mean"] > 0  # a filled jar makes serve-water cheaper
    assert zero["credit_mean"] == 0 and zero["ranks_prepared_higher"] == 0
    _walk_dataset(minimal, tmp_path / "grid", 20)
    with pytest.raises(DomainError, match="no labelled state"):
        credit([ZeroValue()], str(tmp_path / "grid"), "domains/minimal", "(robot-at b)")
    with pytest.raises(DomainError, match="not a reachable fluent atom"):
        credit([ZeroValue()], str(tmp_path / "grid"), "domains/minimal", "(robot-at moon)")


class _ExactOneTaskUnder(_ExactOneTask):
    """-C_AP / cost_scale under whatever next-task distribution it is given (`set_distribution`)."""

    def __init__(self, model):
        super().__init__(model)
        self.q = None

    def set_distribution(self, probabilities):
        self.q = None if probabilities is None else np.asarray(probabilities, dtype=float)

    def v_ap(self, states):
        from oracles.labelling import expected_cost

        p = self.q if self.q is not None else np.asarray(self.model.tasks.probabilities, dtype=float)
        c = np.array([expected_cost(p / p.sum(), self.label(s).costs) for s in states])
        return -np.round(c, 9) / self.model.cost_scale


def test_value_rank_under_a_markov_stream_conditions_on_each_context(two_room, tmp_path):
    """--stream: per context of cook-then-clean (its start, after each type), the exact C_AP under the layout's
    P against the conditional one, and per value its V_AP with P and with the context's P. A value that is the
    exact C_AP under the distribution it is given ranks perfectly once conditioned and, unconditioned, exactly
    as the exact C_AP under P does; a value with no set_distribution has no conditioned figure. The i.i.d.
    stream has no contexts: a one-line error."""
    from learning.gnn.dataset import save_dataset
    from learning.values.rank import conditional
    from oracles.labelling import Labeller
    from planning.value import ZeroValue

    states = list(dict.fromkeys(two_room.random_walk_states(40, seed=3)))[:14]
    labeller = Labeller(two_room)
    labels = {s: (lab.c_ap, [int(c) for c in lab.costs], lab.seconds) for s in states for lab in [labeller.label(s)]}
    save_dataset(tmp_path / "data", two_room, states, labels, {})
    r = conditional(
        [_ExactOneTaskUnder(two_room), ZeroValue()], str(tmp_path / "data"), "domains/restaurant", "cook-then-clean"
    )
    assert (r["stream"], r["kind"], r["states"]) == ("cook-then-clean", "markov", len(states))
    names = [row["context"] for row in r["contexts"]]
    assert names[0] == "at a reset" and "after serve-water" in names and len(names) == 7
    after_water = r["contexts"][names.index("after serve-water")]
    assert after_water["next_types"]["serve-water"] == pytest.approx(0.6)
    assert sum(after_water["next_types"].values()) == pytest.approx(1.0)
    for row in r["contexts"]:
        exact, zero = row["values"]
        assert exact["conditioned"]["spearman"] == pytest.approx(1.0)
        assert exact["unconditioned"]["spearman"] == pytest.approx(row["exact_under_p"]["spearman"])
        assert zero["conditioned"] is None
        assert zero["unconditioned"]["spearman"] is None  # a constant value ranks nothing (not NaN in the JSON)
    assert min(row["exact_under_p"]["spearman"] for row in r["contexts"]) < 1.0  # conditioning reorders states
    with pytest.raises(DomainError, match="i.i.d. stream"):
        conditional([ZeroValue()], str(tmp_path / "data"), "domains/restaurant", "iid")
