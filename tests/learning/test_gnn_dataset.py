"""The GNN dataset: states from myopic rollouts (and prepared ones), labelled with C_AP, saved and read back."""

import json

import pytest
import torch
from test_graph import fake_embed

from learning.gnn.dataset import ClauseLibrary, DatasetConfig, JointGoal, label_states, load_dataset, save_dataset
from learning.gnn.graph import GraphEncoder
from oracles.labelling import Labeller
from oracles.myopic import MyopicOracle, rollout
from oracles.rollouts import record_states
from planning.errors import DomainError


def oracle(model):
    """The internal myopic oracle, started on a model."""
    o = MyopicOracle("internal")
    o.start(model, None)
    return o


@pytest.fixture(scope="module")
def minimal_states(minimal):
    records = list(rollout(minimal, oracle(minimal), seed=0, n_tasks=4))
    return list(dict.fromkeys(record_states(records)))


def test_record_states_are_post_consumption(minimal, minimal_states):
    """No state where a task's goal holds just before consumption is kept, except as the next world."""
    records = list(rollout(minimal, oracle(minimal), seed=0, n_tasks=4))
    states = record_states(records)
    assert states[0] == records[0].states[0]
    for rec in records:
        assert rec.after in states
        if rec.plan:
            assert rec.states[-1] not in states or rec.states[-1] == rec.after


def test_round_trip(minimal, minimal_states, tmp_path):
    """Write, read: the same graphs, labels, per-task costs and atoms."""
    cfg = DatasetConfig(layout="grid", domain="domains/minimal", workers=1, heuristic="hmax")
    labels = label_states(minimal_states, cfg, tmp_path / "labels.partial.json", progress=False)
    lab = Labeller(minimal, "hmax")
    for s in minimal_states[:3]:
        assert labels[s][0] == pytest.approx(lab.label(s).c_ap)
    enc = GraphEncoder(minimal, embed=fake_embed)
    save_dataset(tmp_path, minimal, minimal_states, labels, {"kinds": ["faithful"] * len(minimal_states)}, enc)
    ds = load_dataset(tmp_path)
    assert len(ds) == len(minimal_states)
    for i, s in enumerate(minimal_states):
        want = enc.encode(s)
        got = ds[i]
        assert torch.equal(got.x, want.x) and torch.equal(got.edge_index, want.edge_index)
        assert torch.equal(got.edge_attr, want.edge_attr)
        assert got.y.item() == pytest.approx(labels[s][0])
        assert got.costs.tolist() == [labels[s][1]]
        atoms = ds.meta["atoms"][i]
        assert minimal.state_from_atoms(atoms) == s
    assert [t["task"] for t in ds.meta["tasks"]] == ["clear(c)", "deliver(b)", "deliver(a)"]


def test_labelling_resumes_from_checkpoint(minimal, minimal_states, tmp_path):
    """Labels already in the checkpoint are not computed again."""
    cfg = DatasetConfig(layout="grid", domain="domains/minimal", workers=1, heuristic="hmax")
    ck = tmp_path / "labels.partial.json"
    first = label_states(minimal_states[:2], cfg, ck, progress=False)
    saved = json.loads(ck.read_text())
    saved["labels"][str(minimal_states[0])][0] = -7.0  # a marker: resumed, not recomputed
    ck.write_text(json.dumps(saved))
    again = label_states(minimal_states[:3], cfg, ck, progress=False)
    assert again[minimal_states[0]][0] == -7.0 and again[minimal_states[1]] == first[minimal_states[1]]
    ck.write_text("{not json")
    with pytest.raises(DomainError, match="corrupt checkpoint"):
        label_states(minimal_states, cfg, ck, progress=False)


def test_one_process_checkpoints_its_labels_as_it_goes(minimal, minimal_states, tmp_path, monkeypatch):
    """With one worker every chunk runs when it is queued: the labels already made reach the checkpoint
    between chunks (an interrupted build keeps them), not only when the last chunk is done."""
    import learning.gnn.dataset as dataset

    monkeypatch.setattr(dataset, "CHECKPOINT_SECONDS", 0.0)
    cfg = DatasetConfig(layout="grid", domain="domains/minimal", workers=1, heuristic="hmax")
    ck = tmp_path / "labels.partial.json"
    seen = []  # labels in the checkpoint when each chunk starts
    real = dataset._label_chunk

    def chunk(states):
        seen.append(len(json.loads(ck.read_text())["labels"]) if ck.is_file() else 0)
        return real(states)

    monkeypatch.setattr(dataset, "_label_chunk", chunk)
    states = minimal_states[:8]
    labels = label_states(states, cfg, ck, progress=False)
    assert len(labels) == len(states) and len(seen) == 4  # chunks of 2
    assert seen == [0, 2, 4, 6]


def test_not_a_dataset_folder(tmp_path):
    with pytest.raises(DomainError, match="not a gnn_dataset folder"):
        load_dataset(tmp_path)


def test_clause_library_is_derived_from_preconditions(three_room):
    lib = ClauseLibrary(three_room)
    texts = {lib.text(k) for k in range(len(lib))}
    assert "(has-water jar_0)" in texts  # the jar filled
    assert "(and (at jar_0 servingtable) (has-water jar_0))" in texts  # ... and parked where water is drawn
    assert "(at water_machine coffeemachine)" in texts  # the machine water restored
    assert "(not (dirty cup_1))" in texts  # an object clean
    assert not any("robot-at" in t or "hand-free" in t or "holding" in t for t in texts)


def test_eligible_clauses_are_false_and_costly(three_room):
    from planning.domain.batched import BatchedModel
    from planning.heuristics.hmax import HMax

    lib = ClauseLibrary(three_room)
    bm = BatchedModel(three_room)
    hmax = HMax(three_room, bm)
    eligible = {lib.text(k) for k in lib.eligible(three_room.init, hmax, bm, 200)}
    assert "(has-water jar_0)" in eligible and "(not (dirty cup_1))" in eligible
    assert "(at water_machine coffeemachine)" not in eligible  # true at the start
    assert "(at cup_0 shelf)" not in eligible  # pick undoes it: not a clause
    assert "(dirty cup_0)" not in eligible  # wash undoes it: not a clause


def test_joint_goal(three_room):
    lib = ClauseLibrary(three_room)
    k = [lib.text(i) for i in range(len(lib))].index("(has-water jar_0)")
    goal = JointGoal(three_room.tasks.get("clear(servingtable)"), *lib.masks[k])
    m = three_room
    s = m.state_from_atoms(["(robot-at fountain)", "(hand-free)", "(has-water jar_0)", "(at jar_0 fountain)"])
    assert goal.satisfied(s)
    assert not goal.satisfied(m.init)


def test_augmented_build_is_the_same_for_any_number_of_workers(minimal, tmp_path):
    """Prepared streams collected and labelled in two processes give the dataset one process gives."""
    from learning.gnn.dataset import build

    metas = []
    for workers in (1, 2):
        cfg = DatasetConfig(
            layout="grid",
            domain="domains/minimal",
            n_states=6,
            augmented=True,
            n_prepared=10,
            workers=workers,
            heuristic="hmax",
            min_clause_cost=1,
            prepared_streams=3,
        )
        build(cfg, tmp_path / str(workers), progress=False)
        metas.append(json.loads((tmp_path / str(workers) / "meta.json").read_text()))
    one, two = metas
    assert one["kinds"] == ["faithful"] * 6 + ["prepared"] * 10
    assert one["atoms"] == two["atoms"] and one["c_ap"] == two["c_ap"]
    assert len({tuple(a) for a in one["atoms"]}) == 16  # distinct states
    lab = Labeller(minimal, "hmax")
    for atoms, c_ap in list(zip(one["atoms"], one["c_ap"]))[6:9]:
        assert c_ap == pytest.approx(lab.label(minimal.state_from_atoms(atoms)).c_ap)
    rows = [json.loads((tmp_path / "1" / f"prepared-rollout-{i}.json").read_text()) for i in range(3)]
    assert [r["seed"] for r in rows] == [1, 2, 3]
    assert any(t["clause"] for r in rows for t in r["tasks"])  # tasks planned with a clause


class _CreatesFile:
    """A pickle whose loading would create a file (the code-execution hole of a weights_only=False load)."""

    def __init__(self, path):
        self.path = str(path)

    def __reduce__(self):
        return (open, (self.path, "w"))


def test_a_hostile_dataset_file_is_refused_and_nothing_of_it_runs(tmp_path):
    (tmp_path / "processed").mkdir()
    (tmp_path / "meta.json").write_text("{}")
    marker = tmp_path / "pwned"
    torch.save((_CreatesFile(marker), {}, None), tmp_path / "processed" / "data.pt")
    with pytest.raises(DomainError) as e:
        load_dataset(tmp_path)
    assert "\n" not in str(e.value) and str(tmp_path / "processed" / "data.pt") in str(e.value)
    assert "refused as a gnn dataset" in str(e.value)
    assert not marker.exists()
    # torch_geometric's own step would load processed/pre_transform.pt with weights_only=False
    torch.save(_CreatesFile(marker), tmp_path / "processed" / "pre_transform.pt")
    with pytest.raises(DomainError):
        load_dataset(tmp_path)
    assert not marker.exists()
