"""The one-task GNN baseline: the model's size, training, checkpoints, the value plug-in and native selection."""

import json
import pickle

import numpy as np
import pytest
import torch
from test_graph import fake_embed

from learning.agents.gnn_native import GNNNativePlanner, candidate_accuracy, select
from learning.gnn.candidates import Region
from learning.gnn.dataset import DatasetConfig, label_states, load_dataset, save_dataset
from learning.gnn.graph import GraphEncoder
from learning.gnn.model import (
    THESIS_FEATURES,
    THESIS_PARAMETERS,
    GNNCostModel,
    InferenceGNN,
    load_gnn,
    parameter_count,
    read_gnn_checkpoint,
    save_gnn_checkpoint,
)
from learning.gnn.training import TrainConfig, build_model, evaluate_l1, split, train
from learning.gnn.value import GNNValue
from planning.errors import DomainError
from planning.value import Value


def test_parameter_count_is_the_thesis_number():
    """4 TransformerConv(64, one head) + BatchNorm, mean + add pool, linear head: 152,897 on 399 features."""
    assert parameter_count(GNNCostModel(THESIS_FEATURES)) == THESIS_PARAMETERS == 152_897
    # the readings the number rules out: edge features (64 x edge_dim per layer) and concatenated pools
    assert parameter_count(GNNCostModel(THESIS_FEATURES, edge_dim=6)) == THESIS_PARAMETERS + 4 * 6 * 64


@pytest.fixture(scope="module")
def encoder(minimal):
    return GraphEncoder(minimal, embed=fake_embed)


@pytest.fixture(scope="module")
def dataset(minimal, encoder, tmp_path_factory):
    """Every distinct state of seeded random walks on the grid, labelled with the exact C_AP."""
    root = tmp_path_factory.mktemp("gnn-data")
    states = list(dict.fromkeys(minimal.random_walk_states(400, 0, walk=20)))
    cfg = DatasetConfig(layout="grid", domain="domains/minimal", workers=1, heuristic="hmax")
    labels = label_states(states, cfg, root / "labels.partial.json", progress=False)
    save_dataset(root, minimal, states, labels, {"kinds": ["faithful"] * len(states)}, encoder)
    return root


def test_split_is_seeded_and_80_20():
    tr, va = split(50, 4)
    assert len(va) == 10 and len(tr) == 40 and not set(tr) & set(va)
    assert np.array_equal(split(50, 4)[1], va) and not np.array_equal(split(50, 8)[1], va)


def test_training_lowers_validation_l1(dataset, tmp_path):
    ds = load_dataset(dataset)
    cfg = TrainConfig(data=str(dataset), seed=0, epochs=8)
    _, val_idx = split(len(ds), 0)
    before = evaluate_l1(build_model(cfg, ds[0].x.shape[1], ds[0].edge_attr.shape[1]), ds[torch.from_numpy(val_idx)])
    s = train(cfg, tmp_path, progress=False)
    assert s["best_val_l1"] < 0.5 * before
    rows = [json.loads(line) for line in (tmp_path / "metrics.jsonl").read_text().splitlines()]
    assert [r["epoch"] for r in rows] == list(range(1, 9)) and rows[0]["lr"] == 0.01
    net, payload = load_gnn(tmp_path / "best.pt")
    assert payload["val_l1"] == pytest.approx(s["best_val_l1"])
    assert evaluate_l1(net, ds[torch.from_numpy(val_idx)]) == pytest.approx(s["best_val_l1"], rel=1e-5)


def test_resumed_training_is_the_uninterrupted_run(dataset, tmp_path):
    straight = train(TrainConfig(data=str(dataset), seed=4, epochs=3), tmp_path / "a", progress=False)
    train(TrainConfig(data=str(dataset), seed=4, epochs=1), tmp_path / "b", progress=False)
    resumed = train(TrainConfig(data=str(dataset), seed=4, epochs=3), tmp_path / "b", progress=False)
    assert resumed["best_val_l1"] == pytest.approx(straight["best_val_l1"])
    strip = lambda p: [{k: v for k, v in json.loads(x).items() if k != "seconds"} for x in p.read_text().splitlines()]
    assert strip(tmp_path / "a" / "metrics.jsonl") == strip(tmp_path / "b" / "metrics.jsonl")
    with pytest.raises(DomainError, match="other settings"):
        train(TrainConfig(data=str(dataset), seed=8, epochs=3), tmp_path / "b", progress=False)


def test_checkpoint_round_trip_and_refusals(encoder, tmp_path):
    torch.manual_seed(0)
    net = GNNCostModel(encoder.num_features).eval()
    path = save_gnn_checkpoint(
        tmp_path / "gnn.pt",
        {"model": net.state_dict(), "dims": net.dims, "feature_names": encoder.feature_names, "epoch": 3},
    )
    back, payload = load_gnn(path)
    g = encoder.encode(encoder.model.init)
    assert torch.equal(back.predict(g), net.predict(g)) and payload["epoch"] == 3
    (tmp_path / "evil.pt").write_bytes(pickle.dumps({"x": print}))
    with pytest.raises(DomainError, match="refused|not a readable"):
        read_gnn_checkpoint(tmp_path / "evil.pt")
    torch.save({"net": {}}, tmp_path / "other.pt")
    with pytest.raises(DomainError, match="not a GNN checkpoint"):
        read_gnn_checkpoint(tmp_path / "other.pt")


@pytest.fixture(scope="module")
def value(minimal, encoder):
    torch.manual_seed(1)
    net = GNNCostModel(encoder.num_features).eval()
    return GNNValue((net, {"feature_names": encoder.feature_names}), minimal, encoder=encoder)


def test_value_honours_the_protocol(minimal, value):
    states = list(dict.fromkeys(minimal.random_walk_states(60, 1)))[:12]
    assert isinstance(value, Value) and value.gamma == 1.0
    calls = value.forward_calls
    c = value.c_ap(states)
    assert value.forward_calls == calls + 1 and c.shape == (len(states),)  # one forward pass per batch
    task = minimal.tasks.get("clear(c)")
    assert np.allclose(value.v_ap(states), -c / value.scale) and np.allclose(
        value.q_max(states, task), -c / value.scale
    )
    with torch.no_grad():
        one = [float(value.net.predict(value.encoder.encode(s))) for s in states]  # batched = one by one
    assert np.allclose(c, one, atol=1e-4)
    assert value.forward_calls == calls + 1  # cached
    assert value.v_ap([]).shape == (0,)


def test_value_in_chunks_is_the_value_in_one_pass(minimal, value, monkeypatch):
    import learning.gnn.value as gv

    states = list(dict.fromkeys(minimal.random_walk_states(80, 4)))[:13]
    value._cache.clear()
    whole = value.c_ap(states)
    value._cache.clear()
    monkeypatch.setattr(gv, "CHUNK", 5)
    calls = value.forward_calls
    assert np.allclose(value.c_ap(states), whole, atol=1e-4) and value.forward_calls == calls + 3


def test_value_with_a_full_cache_still_answers_every_state(minimal, encoder):
    """A call that overflows the cache keeps the cached states it asks for (it once dropped them: KeyError)."""
    torch.manual_seed(1)
    net = GNNCostModel(encoder.num_features).eval()
    small = GNNValue((net, {"feature_names": encoder.feature_names}), minimal, encoder=encoder, cache_size=6)
    states = list(dict.fromkeys(minimal.random_walk_states(80, 5)))[:10]
    first = small.c_ap(states[:4])
    both = small.c_ap(states[:4] + states[4:8])  # 4 cached + 4 new > 6
    assert np.allclose(both[:4], first) and len(small._cache) <= 8


@pytest.mark.parametrize("edge_dim", [None, "relations"])
def test_inference_forward_is_the_modules(minimal, encoder, edge_dim):
    """InferenceGNN (joined maps, folded batch norm, first layer through the base graph) = the module in eval."""
    from learning.gnn.value import collate

    torch.manual_seed(3)
    net = GNNCostModel(encoder.num_features, edge_dim=len(encoder.relation_names) if edge_dim else None)
    for norm in net.norms:  # running statistics other than the identity
        norm.running_mean.uniform_(-1, 1)
        norm.running_var.uniform_(0.5, 2)
    net.eval()
    states = list(dict.fromkeys(minimal.random_walk_states(60, 2)))[:9]
    x, index, attr, batch = collate([encoder.arrays(s) for s in states])
    with torch.no_grad():
        want = net(x, index, batch, attr, num_graphs=len(states))
    for base in (None, encoder.base):
        got = InferenceGNN(net, base)(x, index, batch, attr, num_graphs=len(states))
        assert torch.allclose(got, want, rtol=1e-5, atol=1e-4)
    # without the batch's last node the graphs are no longer whole copies of the base: the plain product
    keep = (index < len(x) - 1).all(0)
    args = (x[:-1], index[:, keep], batch[:-1], attr[keep])
    with torch.no_grad():
        want = net(*args, num_graphs=len(states))
    assert torch.allclose(InferenceGNN(net, encoder.base)(*args, num_graphs=len(states)), want, rtol=1e-5, atol=1e-4)


def test_value_refuses_another_layouts_model(minimal, encoder):
    net = GNNCostModel(encoder.num_features + 1)
    with pytest.raises(DomainError, match="node features"):
        GNNValue((net, {"feature_names": ["x"] * (encoder.num_features + 1)}), minimal, encoder=encoder)


def test_select_lowest_score_myopic_kept_on_ties():
    assert select([10, 12, 11], [5.0, 1.0, 4.0]) == 1  # 15, 13, 15
    assert select([10, 12], [5.0, 3.0]) == 0  # 15, 15: a tie keeps the myopic plan
    assert select([10, 12, 11], [5.0, 3.0, 4.0]) == 0
    assert select([10, 11, 11], [5.0, 3.0, 3.0]) == 1  # the first of tied strictly better ones
    assert select([7], [0.0]) == 0


def _detour(minimal, state, task, myopic):
    """A costlier plan for the task: one step away and back first, completing the task at its end."""
    region = Region(minimal)
    here = region.agent_at(state)
    away = sorted(region.moves[here])[0]
    plan = [minimal.action(f"move({here}, {away})"), minimal.action(f"move({away}, {here})")] + list(myopic)
    s = state
    for a in plan[:-1]:
        s = minimal.apply(s, a)
        assert not task.satisfied(s)
    return plan


@pytest.mark.parametrize("bonus, chosen", [(-3.0, "detour"), (-2.0, "myopic"), (0.0, "myopic")])
def test_native_selection_with_a_stub_estimator(minimal, monkeypatch, bonus, chosen):
    """The detour costs 2 more; an estimate lower by more than 2 at its end wins, lower by exactly 2 ties."""
    task = minimal.tasks.get("clear(c)")
    state = minimal.init
    seen = []

    def estimate(states):  # the stub: 0 for the myopic end state, `bonus` for the detour's
        seen.append(list(states))
        return np.array([0.0, bonus][: len(states)])

    agent = GNNNativePlanner(minimal, "stub", estimate=estimate)
    agent.start(minimal, None)
    myopic = agent.reference.plan(state, task, []).plan
    detour = _detour(minimal, state, task, myopic)
    monkeypatch.setattr(agent, "clause_plans", lambda s, t, p: ([("detour", detour)], 0, 1, True))
    r = agent.plan(state, task, [])
    assert r.info["chosen"] == chosen and r.info["candidates"] == 2
    assert r.plan == (detour if chosen == "detour" else myopic)
    assert r.info["candidate_costs"] == [len(myopic), len(myopic) + 2]
    assert len(seen) == 1 and seen[0] == [task.consume(agent._path(state, p)[-1]) for p in (myopic, detour)]


def test_candidate_cache_replays_what_was_planned(minimal, monkeypatch, tmp_path):
    """A second agent on the same cache file plans nothing and replies alike; a half-written last line is
    skipped; a file made with other settings is a one-line error naming it."""
    task, path = minimal.tasks.get("clear(c)"), tmp_path / "candidates.jsonl"
    zero = lambda states: np.zeros(len(states))
    first = GNNNativePlanner(minimal, "stub", estimate=zero, candidates=str(path))
    first.start(minimal, None)
    r1 = first.plan(minimal.init, task, [])
    assert first.cache.misses == 1 and len(path.read_text().splitlines()) == 2  # the header and the entry
    again = GNNNativePlanner(minimal, "stub", estimate=zero, candidates=str(path))
    again.start(minimal, None)
    monkeypatch.setattr(again.reference, "plan", lambda *a: pytest.fail("planned a cached task"))
    r2 = again.plan(minimal.init, task, [])
    assert (r2.plan, r2.info) == (r1.plan, r1.info) and again.cache.hits == 1
    path.write_text(path.read_text() + '{"state": "1f", "ta')
    assert len(GNNNativePlanner(minimal, "stub", estimate=zero, candidates=str(path)).cache.table) == 1
    with pytest.raises(DomainError, match="candidates.jsonl.*max_clauses"):
        GNNNativePlanner(minimal, "stub", max_clauses=3, estimate=zero, candidates=str(path))


def test_candidate_accuracy_against_exact_labels():
    """Task 1: the estimate prefers the detour (20 + 50 < 10 + 100), the exact labels the myopic plan
    (10 + 100 < 20 + 200): a wrong choice costing 110. Task 2: both pick the myopic plan."""
    rows = [
        {"c_ap_hat": [100, 50], "c_ap_exact": [100, 200], "candidate_costs": [10, 20]},
        {"c_ap_hat": [10, 30], "c_ap_exact": [12, 28], "candidate_costs": [5, 5]},
        {"c_ap_hat": [7], "candidate_costs": [3]},
    ]  # no exact labels: not counted
    a = candidate_accuracy(rows)
    assert a["tasks"] == 2 and a["candidates"] == 4 and a["mae"] == 38.5
    assert a["within_task_pairs_right"] == 0.5 and a["same_choice_as_exact"] == 0.5 and a["mean_excess"] == 55.0
    assert a["exact_departs"] == 0.0 and a["exact_gain"] == 0.0  # exact labels keep the myopic plan
    rows[1]["c_ap_exact"] = [12, 2]  # now the detour, 5 + 2 < 5 + 12
    a = candidate_accuracy(rows)
    assert a["exact_departs"] == 0.5 and a["exact_gain"] == 5.0 and a["same_choice_as_exact"] == 0.0
    assert candidate_accuracy(rows[2:]) is None


def test_candidate_region_is_the_myopic_path_plus_one_move(two_room):
    r = Region(two_room)
    here = r.agent_at(two_room.init)
    assert r.around([two_room.init]) == {here} | r.moves[here]
    assert here not in r.moves[here]


def test_gnn_bench_scores_the_validation_split(minimal, encoder, dataset, tmp_path):
    """learning.gnn.bench: its MAE is the trainer's validation L1, its exact reference re-derives the labels."""
    from learning.gnn.bench import bench, pair_agreement

    assert pair_agreement(np.array([1.0, 2.0, 3.0]), np.array([10.0, 30.0, 20.0])) == pytest.approx(2 / 3)
    s = train(TrainConfig(data=str(dataset), seed=0, epochs=2), tmp_path, progress=False)
    r = bench(
        str(tmp_path / "best.pt"), str(dataset), "domains/minimal", batch=6, repeats=2, n_exact=5, encoder=encoder
    )
    assert r["validation"]["mae"] == pytest.approx(s["best_val_l1"], abs=0.01)
    assert r["inference"]["batch"] == 6 and r["exact"]["states"] == 5
    assert -1.0 <= r["validation"]["spearman"] <= 1.0


def test_compact_gnn_checkpoint_predicts_as_the_full_one(dataset, tmp_path):
    """learning.export on a GNN run: float16 weights, about half the bytes, float32 again on load, the same Ĉ_AP
    to float16 rounding; its figures are the run's summary."""
    from torch_geometric.loader import DataLoader

    from learning.export import default_names, export_gnn, is_gnn_run

    s = train(TrainConfig(data=str(dataset), seed=0, epochs=2), tmp_path / "run", progress=False)
    assert is_gnn_run(tmp_path / "run")
    with pytest.raises(DomainError, match="variant"):  # the test dataset's meta has no generator config
        default_names(tmp_path / "run", gnn=True)
    small, figs = export_gnn(tmp_path / "run", tmp_path / "small.pt", tmp_path / "figs.json")
    assert figs["best_val_l1"] == s["best_val_l1"] and small["precision"] == "float16"
    assert (tmp_path / "small.pt").stat().st_size < 0.6 * (tmp_path / "run" / "best.pt").stat().st_size
    (full, _), (half, payload) = load_gnn(tmp_path / "run" / "best.pt"), load_gnn(tmp_path / "small.pt")
    assert all(v.dtype != torch.float16 for v in payload["model"].values())
    batch = next(iter(DataLoader(load_dataset(dataset), batch_size=64)))
    with torch.no_grad():
        a, b = full.predict(batch), half.predict(batch)
    torch.testing.assert_close(b, a, rtol=5e-3, atol=0.5)


class _LabelValue:
    """A value that knows the exact C_AP of the dataset's states (or its negation: the worst ranking)."""

    def __init__(self, minimal, dataset, sign: float):
        meta = json.loads((dataset / "meta.json").read_text())
        self.gamma, self.sign = 1.0, sign
        self.c = {minimal.state_from_atoms(a): c for a, c in zip(meta["atoms"], meta["c_ap"])}

    def q_max(self, states, task):
        return self.v_ap(states)

    def v_ap(self, states):
        return np.array([-self.sign * self.c[s] / 100 for s in states])


def test_value_rank_scores_the_exact_ranking_one_and_its_reverse_minus_one(minimal, dataset):
    from learning.values.rank import rank

    r = rank([_LabelValue(minimal, dataset, 1.0), _LabelValue(minimal, dataset, -1.0)], str(dataset), "domains/minimal")
    exact, reverse = r["values"][0]["all"], r["values"][1]["all"]
    assert exact["states"] == reverse["states"] == r["states"] > 20
    assert exact["spearman"] == exact["kendall"] == exact["pair_agreement"] == 1.0
    assert exact["slope_rl_per_pddl"] == pytest.approx(0.01)
    assert reverse["spearman"] == reverse["kendall"] == -1.0 and reverse["pair_agreement"] == 0.0
    assert reverse["slope_rl_per_pddl"] == pytest.approx(-0.01)


def test_value_rank_scores_a_gnn_only_on_states_it_did_not_learn(
    minimal, encoder, dataset, value, tmp_path, monkeypatch
):
    import learning.values.rank as vr

    train(TrainConfig(data=str(dataset), seed=0, epochs=1), tmp_path, progress=False)
    monkeypatch.setattr(vr, "load_value", lambda path, model: GNNValue(path, model, encoder=encoder))
    row = vr.rank([str(tmp_path / "best.pt")], str(dataset), "domains/minimal")["values"][0]
    n = json.loads((dataset / "meta.json").read_text())["n"]
    assert row["scored_on"] == "the validation split of its own training run"
    assert row["all"]["states"] == len(split(n, 0)[1]) < n
    # on another dataset: only the states outside its training set (datasets made alike share many states)
    from planning.domain.grounding import atom_text

    meta = json.loads((dataset / "meta.json").read_text())
    seen = {minimal.state_from_atoms(a) for a in meta["atoms"]}
    new = [s for s in dict.fromkeys(minimal.random_walk_states(400, 7, walk=40)) if s not in seen][:4]
    assert len(new) == 4
    atoms = meta["atoms"][:10] + [[atom_text(k) for k in minimal.true_atoms(s)] for s in new]
    other = tmp_path / "other"
    other.mkdir()
    (other / "meta.json").write_text(
        json.dumps({"domain": minimal.name, "layout": "grid", "n": 14, "c_ap": list(range(14)), "atoms": atoms})
    )
    row = vr.rank([str(tmp_path / "best.pt")], str(other), "domains/minimal")["values"][0]
    assert row["all"]["states"] == 4 and row["scored_on"] == f"the 4 states not in its training set ({dataset})"
    # its training set not at hand: every state, and the row says so
    moved = dataset.with_name(dataset.name + "-moved")
    dataset.rename(moved)
    try:
        row = vr.rank([str(tmp_path / "best.pt")], str(other), "domains/minimal")["values"][0]
    finally:
        moved.rename(dataset)
    assert row["all"]["states"] == 14 and row["scored_on"].startswith("every state: its training set")
    row = vr.rank([value], str(other), "domains/minimal")["values"][0]  # a model that records no training set
    assert row["all"]["states"] == 14 and row["scored_on"] == "every state: the model records no training set"


def test_dataset_export_writes_its_key_figures(dataset, tmp_path, capsys, monkeypatch):
    """A dataset folder is committed as its key figures: states per kind and the labels' spread, from meta.json."""
    import sys

    from learning import export

    meta = json.loads((dataset / "meta.json").read_text())
    out = tmp_path / "dataset.json"
    sys.argv = ["export", str(dataset), "--figures", str(out)]
    export.main()
    d = json.loads(out.read_text())
    assert d["states"] == meta["n"] == len(meta["c_ap"]) and d["kinds"] == {"faithful": meta["n"]}
    assert d["variant"] == "faithful" and d["layout"] == "grid"
    assert d["c_ap"]["mean"] == pytest.approx(np.mean(meta["c_ap"]), abs=0.01)
    assert d["c_ap"]["max"] == pytest.approx(max(meta["c_ap"]), abs=0.01) and "provenance" in d
    assert f"{meta['n']:,} states" in capsys.readouterr().out
    sys.argv = ["export", str(dataset), "--out", str(tmp_path / "x.pt")]
    with pytest.raises(SystemExit) as e:  # a dataset has no checkpoint to write
        export.main()
    assert e.value.code != 0
    monkeypatch.chdir(tmp_path)  # the default name: a domain other than the restaurant comes first
    sys.argv = ["export", str(dataset)]
    export.main()
    default = json.loads((tmp_path / "results" / "minimal-dataset-gnn-faithful-grid.json").read_text())
    assert {k: v for k, v in default.items() if k != "provenance"} == {k: v for k, v in d.items() if k != "provenance"}
