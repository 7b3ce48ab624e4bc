"""More bad input: files made for another layout or other domain content, outputs that would be
replaced silently, and the tracebacks that are one-line errors now. Tiny data only: crafted files and the
committed checkpoints, nothing trained."""

import fcntl
import json
import os
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from planning import cli
from planning.domain.compiler import _compile_cached, compile_domain
from planning.domain.identity import identity
from planning.errors import DomainError

ROOT = Path(__file__).resolve().parents[1]
MINIMAL = str(ROOT / "domains" / "minimal")
RESTAURANT = str(ROOT / "domains" / "restaurant")
TWO_ROOM_GNN = str(ROOT / "checkpoints" / "gnn-faithful-two-room-seed0.pt")
OTHER_DIGEST = "0" * 64


def one_line(e) -> str:
    text = str(e.value)
    assert "\n" not in text
    return text


def exits(main, argv, capsys) -> str:
    """Run `main` as its command does (cli.run, sys.argv): exit 2 and one error line, which is returned."""
    before = sys.argv
    sys.argv = ["prog", *map(str, argv)]
    try:
        with pytest.raises(SystemExit) as e:
            cli.run(main)
    finally:
        sys.argv = before
    err = capsys.readouterr().err
    lines = [line for line in err.replace("\r", "\n").splitlines() if line.strip()]
    assert e.value.code == 2, err
    assert "Traceback" not in err and lines and lines[-1].startswith("error: "), err
    return lines[-1]


def zero_embed(names):
    """No sentence model: every name the same vector (the graphs' shapes are what these tests need)."""
    return np.zeros((len(names), 384), dtype=np.float32)


def dataset_meta(model, states, **extra) -> dict:
    """The meta.json a gnn_dataset folder of these states would have (labels made up)."""
    from planning.domain.grounding import atom_text

    return {
        "domain": model.name,
        "layout": model.layout,
        "n": len(states),
        "kinds": ["faithful"] * len(states),
        "c_ap": [100.0 + i for i in range(len(states))],
        "atoms": [[atom_text(k) for k in model.true_atoms(s)] for s in states],
        **extra,
    }


def three_room_data(tmp_path, three_room) -> Path:
    folder = tmp_path / "three-room-data"
    folder.mkdir()
    states = three_room.random_walk_states(6, seed=0)
    (folder / "meta.json").write_text(json.dumps(dataset_meta(three_room, list(dict.fromkeys(states)))))
    return folder


# ---- 1. a GNN model or dataset of another layout ------------------------------------------------------
def test_a_gnn_model_of_another_layout_is_refused_by_its_value(three_room):
    from learning.gnn.value import GNNValue

    with pytest.raises(DomainError) as e:
        GNNValue(TWO_ROOM_GNN, three_room)
    assert one_line(e) == (f"{TWO_ROOM_GNN}: a GNN model of restaurant two-room, not of restaurant three-room")


@pytest.mark.parametrize("agent", [["gnn-guided"], ["gnn-native", "--candidates", "none"]])
def test_gnn_agents_refuse_a_model_of_another_layout(three_room, tmp_path, capsys, agent):
    from experiments.evaluate import main

    line = exits(
        main,
        [
            "--agent",
            *agent,
            "--model",
            TWO_ROOM_GNN,
            "--layout",
            "three-room",
            "--sequences",
            "0",
            "--out",
            tmp_path / "r.json",
        ],
        capsys,
    )
    assert f"{TWO_ROOM_GNN}: a GNN model of restaurant two-room, not of restaurant three-room" in line
    assert not list(tmp_path.iterdir())


def test_value_rank_and_gnn_bench_refuse_a_model_of_another_layout(three_room, tmp_path, capsys):
    from learning.gnn import bench as gnn_bench
    from learning.values import rank as value_rank

    data = three_room_data(tmp_path, three_room)
    with pytest.raises(DomainError, match="a GNN model of restaurant two-room, not of restaurant three-room"):
        value_rank.rank([TWO_ROOM_GNN], str(data), RESTAURANT)
    with pytest.raises(DomainError, match="a GNN model of restaurant two-room, not of restaurant three-room"):
        gnn_bench.bench(TWO_ROOM_GNN, str(data), RESTAURANT, batch=2, repeats=1, n_exact=1)
    out = tmp_path / "rank.json"
    line = exits(value_rank.main, ["--data", data, "--value", TWO_ROOM_GNN, "--out", out], capsys)
    assert line.startswith(f"error: {TWO_ROOM_GNN}: a GNN model of restaurant two-room")
    line = exits(gnn_bench.main, ["--model", TWO_ROOM_GNN, "--data", data, "--out", out], capsys)
    assert line.startswith(f"error: {TWO_ROOM_GNN}: a GNN model of restaurant two-room")
    assert not out.exists()


def test_a_dataset_of_another_domain_is_refused(two_room, tmp_path):
    from learning.values import rank as value_rank

    data = tmp_path / "data"
    data.mkdir()
    (data / "meta.json").write_text(json.dumps({**dataset_meta(two_room, [two_room.init]), "domain": "minimal"}))
    with pytest.raises(DomainError) as e:
        value_rank.rank([], str(data), RESTAURANT)
    assert one_line(e) == f"{data}/meta.json: a dataset of minimal two-room, not of restaurant two-room"


def test_gnn_train_checks_the_dataset_against_its_layout(minimal, tmp_path, capsys):
    from learning.gnn_train import main

    data = tmp_path / "data"
    data.mkdir()
    (data / "meta.json").write_text(json.dumps({**dataset_meta(minimal, [minimal.init]), "layout": "ring"}))
    line = exits(main, ["--data", data, "--domain", MINIMAL, "--layout", "grid", "--out", tmp_path / "run"], capsys)
    assert line == f"error: {data}/meta.json: a dataset of minimal ring, not of minimal grid"


def test_new_datasets_and_models_record_the_domain_identity(minimal, tmp_path):
    from learning.gnn.dataset import save_dataset
    from learning.gnn.graph import GraphEncoder
    from learning.gnn.model import GNNCostModel
    from learning.gnn.training import TrainConfig, _payload

    states = list(dict.fromkeys(minimal.random_walk_states(4, seed=0)))
    labels = {s: (10.0, [10] * len(minimal.tasks), 0.0) for s in states}
    save_dataset(
        tmp_path,
        minimal,
        states,
        labels,
        {"kinds": ["faithful"] * len(states)},
        GraphEncoder(minimal, embed=zero_embed),
    )
    meta = json.loads((tmp_path / "meta.json").read_text())
    assert {k: meta[k] for k in ("domain", "domain_sha256", "domain_files")} == identity(minimal)
    assert meta["layout"] == "grid"
    net = GNNCostModel(len(meta["feature_names"]), width=4, layers=1)
    payload = _payload(net, TrainConfig(data=str(tmp_path)), meta, 1, 1.0, np.arange(3), np.arange(1))
    assert payload["domain_sha256"] == identity(minimal)["domain_sha256"] and payload["layout"] == "grid"


def test_a_model_of_other_domain_content_loads_with_a_one_line_warning(minimal, capsys):
    from learning.gnn.graph import GraphEncoder
    from learning.gnn.model import GNNCostModel
    from learning.gnn.value import GNNValue

    enc = GraphEncoder(minimal, embed=zero_embed)
    net = GNNCostModel(enc.num_features, width=4, layers=1).eval()
    payload = {
        "feature_names": enc.feature_names,
        **identity(minimal),
        "layout": "grid",
        "domain_sha256": OTHER_DIGEST,
        "domain_files": {**identity(minimal)["domain_files"], "grid.pddl": "x"},
    }
    value = GNNValue((net, payload), minimal, encoder=enc)
    assert value.c_ap([minimal.init]).shape == (1,)
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "warning: GNN model: a GNN model made from other content of domain 'minimal' (changed: "
        "grid.pddl); its C_AP figures may not hold for this content"
    ]
    GNNValue((net, {**payload, **identity(minimal)}), minimal, encoder=enc)  # the same content: no warning
    assert capsys.readouterr().err == ""


def test_the_committed_gnn_models_load_on_their_own_layout(two_room):
    from learning.gnn.model import check_made_for, read_gnn_checkpoint

    payload = read_gnn_checkpoint(TWO_ROOM_GNN)
    assert "domain_sha256" not in payload  # made before models recorded it: taken as it is
    check_made_for(TWO_ROOM_GNN, payload, two_room)


# ---- 2. a dataset folder that would be replaced silently -----------------------------------------------
def tiny_cfg(**kw):
    from learning.gnn.dataset import DatasetConfig

    return DatasetConfig(
        **{"layout": "grid", "domain": MINIMAL, "n_states": 4, "workers": 1, "heuristic": "hmax", **kw}
    )


def test_a_finished_dataset_is_not_replaced_by_another_unless_forced(tmp_path, monkeypatch):
    from learning.gnn.dataset import build

    monkeypatch.chdir(tmp_path)  # the rollout cache goes to runs/ here
    out = tmp_path / "data"
    build(tiny_cfg(), out, progress=False)
    finished = (out / "meta.json").read_bytes()
    build(tiny_cfg(workers=2, heuristic="blind"), out, progress=False)  # the same dataset: rebuilt as it was
    assert json.loads((out / "meta.json").read_text())["atoms"] == json.loads(finished)["atoms"]
    with pytest.raises(DomainError) as e:
        build(tiny_cfg(n_states=5), out, progress=False)
    assert one_line(e) == (
        f"{out}/meta.json: a finished dataset of other settings (n_states 4 there, 5 here); "
        "pass --force to replace it, or --out another folder"
    )
    assert json.loads((out / "meta.json").read_text())["n"] == 4
    build(tiny_cfg(n_states=5), out, progress=False, force=True)
    assert json.loads((out / "meta.json").read_text())["n"] == 5
    assert not (out / ".lock").exists()


def test_a_finished_dataset_of_another_layout_or_content_is_refused(minimal, tmp_path):
    from learning.gnn.dataset import build

    out = tmp_path / "data"
    out.mkdir()
    for meta, what in [
        ({"domain": "restaurant", "layout": "two-room"}, "restaurant two-room, not minimal grid"),
        ({**identity(minimal), "layout": "grid", "domain_sha256": OTHER_DIGEST}, "other content of domain 'minimal'"),
    ]:
        (out / "meta.json").write_text(json.dumps(meta))
        with pytest.raises(DomainError) as e:
            build(tiny_cfg(), out, progress=False)
        assert one_line(e).startswith(f"{out}/meta.json: a finished dataset of {what}")
        assert json.loads((out / "meta.json").read_text()) == meta


def test_the_dataset_command_has_a_default_folder(minimal, tmp_path, monkeypatch, capsys):
    """`--augmented` without --out writes runs/gnn/DOMAIN-LAYOUT-augmented (here: a finished one of another
    layout is there, so the command stops before any work, naming it)."""
    from learning.gnn.dataset import default_out
    from learning.gnn_dataset import main

    assert default_out(compile_domain(RESTAURANT, "two-room"), True) == Path("runs/gnn/restaurant-two-room-augmented")
    monkeypatch.chdir(tmp_path)
    folder = tmp_path / "runs" / "gnn" / "minimal-grid-augmented"
    folder.mkdir(parents=True)
    (folder / "meta.json").write_text(json.dumps({"domain": "minimal", "layout": "ring"}))
    line = exits(main, ["--domain", MINIMAL, "--augmented", "--no-progress"], capsys)
    assert line.startswith("error: runs/gnn/minimal-grid-augmented/meta.json: a finished dataset of minimal ring")
    assert "--out: a dataset folder is required" not in line


def test_a_dataset_folder_has_one_writer(tmp_path):
    from learning.gnn.dataset import build

    out = tmp_path / "data"
    out.mkdir()
    fd = os.open(out / ".lock", os.O_RDWR | os.O_CREAT)  # another writer holds the folder
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        with pytest.raises(DomainError) as e:
            build(tiny_cfg(), out, progress=False)
        assert one_line(e).startswith(f"{out}: another process is writing this dataset")
    finally:
        os.close(fd)
    assert not (out / "meta.json").exists()


# ---- 3. tracebacks that are one-line errors ------------------------------------------------------------
@pytest.mark.parametrize(
    "value, expect",
    [
        ("7", "task wash: arguments is 7, not a table like"),
        ('"bowls"', "task wash: arguments is 'bowls', not a table like"),
        ('{ "?k" = [3] }', "task wash: ?k lists 3, not an object name"),
        ('{ "?k" = [] }', "task wash: ?k names no object"),
    ],
)
def test_a_tasks_table_of_the_wrong_types(tmp_path, value, expect):
    from planning.domain.compiler import compile_source
    from planning.domain.folder import read_domain

    folder = tmp_path / "restaurant"
    shutil.copytree(RESTAURANT, folder)
    path = folder / "domain.toml"
    path.write_text(
        path.read_text().replace('arguments = { "?k" = { bowls = 0.5, knives = 0.5 } }', f"arguments = {value}")
    )
    with pytest.raises(DomainError) as e:
        compile_source(read_domain(folder, "two-room"))
    assert one_line(e).startswith(f"{path}: {expect}")


def test_an_unknown_key_of_a_tasks_table(tmp_path):
    from planning.domain.compiler import compile_source
    from planning.domain.folder import read_domain

    folder = tmp_path / "restaurant"
    shutil.copytree(RESTAURANT, folder)
    path = folder / "domain.toml"
    path.write_text(path.read_text().replace("[tasks.wash]\n", "[tasks.wash]\nargument = 3\n"))
    with pytest.raises(DomainError) as e:
        compile_source(read_domain(folder, "two-room"))
    assert one_line(e) == (
        f"{path}: task wash: unknown key 'argument' (a [tasks.<type>] table has probability and arguments)"
    )


def test_a_cut_short_dataset_meta_is_one_line(minimal, tmp_path, capsys):
    from learning.gnn import bench as gnn_bench
    from learning.gnn.dataset import load_dataset, save_dataset
    from learning.gnn.graph import GraphEncoder
    from learning.gnn_train import main
    from learning.values import rank as value_rank

    states = list(dict.fromkeys(minimal.random_walk_states(4, seed=0)))
    save_dataset(
        tmp_path,
        minimal,
        states,
        {s: (1.0, [1] * len(minimal.tasks), 0.0) for s in states},
        {"kinds": ["faithful"] * len(states)},
        GraphEncoder(minimal, embed=zero_embed),
    )
    meta = tmp_path / "meta.json"
    meta.write_text(meta.read_text()[:100])
    expect = f"{meta}: corrupt dataset metadata ("
    with pytest.raises(DomainError) as e:
        load_dataset(tmp_path)
    assert one_line(e).startswith(expect)
    for call in (
        lambda: value_rank.rank([], str(tmp_path), MINIMAL),
        lambda: gnn_bench.bench(TWO_ROOM_GNN, str(tmp_path), MINIMAL, 2, 1, 1),
    ):
        with pytest.raises(DomainError) as e:
            call()
        assert one_line(e).startswith(expect)
    line = exits(main, ["--data", tmp_path, "--epochs", "1", "--no-progress", "--out", tmp_path / "run"], capsys)
    assert line.startswith(f"error: {expect}")
    line = exits(main, ["--data", tmp_path, "--domain", MINIMAL, "--layout", "grid", "--out", tmp_path / "run"], capsys)
    assert line.startswith(f"error: {expect}")


@pytest.mark.parametrize(
    "text, expect",
    [
        ("[]", "corrupt checkpoint: list [], not a JSON object with a labels table"),
        ('{"labels": [1]}', "corrupt checkpoint: dict"),
        ('{"labels": {"5": 3}}', "corrupt checkpoint: the label of state 5 is 3, not [C_AP, costs, seconds]"),
        ('{"labels": {"x": [1, [1], 0]}}', "corrupt checkpoint: the label of state x is"),
    ],
)
def test_a_malformed_label_checkpoint_is_one_line(minimal, tmp_path, text, expect):
    from learning.gnn.dataset import known_labels, label_states

    ck = tmp_path / "labels.partial.json"
    ck.write_text(text)
    for call in (
        lambda: label_states([minimal.init], tiny_cfg(), ck, progress=False),
        lambda: known_labels([tmp_path], minimal),
    ):
        with pytest.raises(DomainError) as e:
            call()
        assert one_line(e).startswith(f"{ck}: {expect}")
    assert ck.read_text() == text  # not overwritten


# ---- 4. the Gymnasium environment's actions ------------------------------------------------------------
@pytest.fixture(scope="module")
def env():
    from learning.gym_env import AnticipatoryEnv

    return AnticipatoryEnv(MINIMAL)


@pytest.mark.parametrize(
    "action, expect",
    [
        (1.7, "action 1.7 is not an integer of Discrete("),
        (np.float32(0.5), "action np.float32(0.5) is not an integer of Discrete("),
        (True, "action True is not an integer of Discrete("),
        (np.array([1]), "action array([1]) has shape (1,), not () of Discrete("),
        ("1", "action '1' is not an integer of Discrete("),
        (-1, "action -1 is not in Discrete("),
    ],
)
def test_a_non_integer_action_is_refused_naming_it(env, action, expect):
    env.reset(seed=0)
    state = env.state
    with pytest.raises(ValueError) as e:
        env.step(action)
    assert str(e.value).startswith(expect)
    assert env.state == state and env._task_actions == 0  # nothing happened


def test_integer_actions_of_any_kind_are_taken(env):
    _, info = env.reset(seed=0)
    a = int(np.flatnonzero(info["action_mask"])[0])
    for action in (a, np.int64(a), np.int32(a), np.array(a), float(a)):
        env.reset(seed=0)
        _, _, _, _, info = env.step(action)
        assert not info["invalid"] and info["task_actions"] == 1


def test_a_factored_action_must_be_one_integer_per_head():
    from learning.gym_env import AnticipatoryEnv

    env = AnticipatoryEnv(MINIMAL, factored=True)
    env.reset(seed=0)
    heads = len(env.head_sizes)
    with pytest.raises(ValueError, match=r"is not a vector of integers of MultiDiscrete"):
        env.step([0.5] * heads)
    with pytest.raises(ValueError, match=rf"has shape \({heads + 1},\), not \({heads},\)"):
        env.step([0] * (heads + 1))
    env.step(np.zeros(heads, dtype=np.int32))


# ---- 5. the report over a cut-short results file -------------------------------------------------------
def test_reproduce_stops_at_a_cut_short_reference(tmp_path, monkeypatch, capsys):
    from experiments.reproduce import main

    monkeypatch.chdir(tmp_path)
    (tmp_path / "results").mkdir()
    reference = Path("results/myopic-oracle-two-room.json")
    reference.write_text((ROOT / reference).read_text()[:300])
    line = exits(
        main,
        [
            "--report-only",
            "--layouts",
            "two-room",
            "--domain",
            RESTAURANT,
            "--no-progress",
            "--out",
            tmp_path / "report.md",
        ],
        capsys,
    )
    assert line.startswith(f"error: {reference}: corrupt results file (")
    assert "cut short or edited by hand" in line and not (tmp_path / "report.md").exists()


def test_the_report_reads_no_cut_short_file_as_missing(tmp_path, monkeypatch):
    from experiments.report import reference
    from experiments.report.specs import training_logs

    monkeypatch.chdir(tmp_path)
    (tmp_path / "results").mkdir()
    assert reference.read("results/bench-three-room.json") is None  # missing: not run
    Path("results/bench-three-room.json").write_text('{"layout": "three')
    with pytest.raises(DomainError, match=r"^results/bench-three-room.json: corrupt results file"):
        reference.read("results/bench-three-room.json")
    Path("results/training-myopic-two-room-seed4.json").write_text('{"curve": [')
    with pytest.raises(DomainError, match=r"^results/training-myopic-two-room-seed4.json: corrupt training results"):
        training_logs("two-room", "myopic")


# ---- 6. a worker that dies -----------------------------------------------------------------------------
def die_on_two(x):
    """A work item; item 2 kills its worker process (as the kernel's OOM killer would)."""
    if x == 2:
        os._exit(1)
    return 10 * x


def test_a_dead_worker_is_one_line_and_the_finished_items_are_kept():
    from planning.parallel import run_items

    kept = {}
    with pytest.raises(DomainError) as e:
        run_items(
            die_on_two, [0, 1, 2, 3, 4], workers=2, progress=False, on_result=lambda i, r, meta: kept.update({i: r})
        )
    line = one_line(e)
    assert line.startswith("--workers 2: a worker process died (killed, or out of memory); ")
    assert line.endswith(f"{len(kept)} of the 5 items finished and were kept: rerun the command to play the rest")
    assert 2 not in kept and all(r == 10 * i for i, r in kept.items())


@pytest.mark.slow
def test_a_dead_ray_worker_is_one_line(monkeypatch):
    pytest.importorskip("ray")
    from planning.parallel import run_items

    here = str(Path(__file__).parent)  # Ray's workers import this module by name
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, [here, os.environ.get("PYTHONPATH")])))

    with pytest.raises(DomainError) as e:
        run_items(die_on_two, [0, 1, 2, 3], workers=2, use_ray=True, progress=False)
    assert one_line(e).startswith("--ray: a worker process died (WorkerCrashedError); ")


# ---- 7. caches and labels files made from other domain content -----------------------------------------
def test_a_rollout_cache_of_other_domain_content_is_rebuilt(tmp_path):
    from oracles.rollouts import cache_path, cached_rollout, load_records

    folder = tmp_path / "minimal"
    shutil.copytree(MINIMAL, folder)
    model = compile_domain(folder, "grid")
    cached_rollout(model, 0, 3, cache_dir=tmp_path, progress=False)
    path = cache_path(model, 0, "internal", tmp_path)
    assert json.loads(path.read_text())["domain_sha256"] == identity(model)["domain_sha256"]
    toml = folder / "domain.toml"
    toml.write_text(toml.read_text().replace("{ b = 0.8, a = 0.2 }", "{ b = 0.3, a = 0.7 }"))  # other targets
    _compile_cached.cache_clear()
    try:
        edited = compile_domain(folder, "grid")
        with pytest.raises(DomainError) as e:
            load_records(edited, path, 0, "internal")
        assert one_line(e) == (
            f"{path}: a rollout cache made from other content of domain 'minimal' (changed: "
            "domain.toml); delete it to recompute"
        )
        again = cached_rollout(edited, 0, 3, cache_dir=tmp_path, progress=False)  # planned again, replaced
        assert len(again) == 3
        assert json.loads(path.read_text())["domain_sha256"] == identity(edited)["domain_sha256"]
        assert [r.task for r in cached_rollout(edited, 0, 3, cache_dir=tmp_path, progress=False)] == [
            r.task for r in again
        ]
    finally:
        _compile_cached.cache_clear()


def test_a_labels_file_is_not_replaced_by_another_unless_forced(minimal, tmp_path, capsys):
    from oracles.labelling import main

    out = tmp_path / "label.json"
    state = tmp_path / "state.json"
    state.write_text(json.dumps(["(robot-at x1y0)", "(hand-free)", "(at apple c)"]))
    capsys.readouterr()
    sys.argv, before = ["prog", "--domain", MINIMAL, "--out", str(out)], sys.argv
    try:
        main()
        main()  # the same label again: rewritten
    finally:
        sys.argv = before
    saved = json.loads(out.read_text())
    assert {k: saved[k] for k in ("domain", "domain_sha256", "domain_files")} == identity(minimal)
    assert saved["layout"] == "grid" and saved["state"]
    line = exits(main, ["--domain", MINIMAL, "--state", state, "--out", out], capsys)
    assert line == f"error: {out}: a labels file of another state; pass --force to replace it, or --out another file"
    out.write_text(json.dumps({**saved, "domain_sha256": OTHER_DIGEST}))
    line = exits(main, ["--domain", MINIMAL, "--out", out], capsys)
    assert f"{out}: a labels file of other content of domain 'minimal'" in line
    (tmp_path / "results.json").write_text("{}")
    line = exits(main, ["--domain", MINIMAL, "--out", tmp_path / "results.json"], capsys)
    assert "results.json: exists and is not a labels file; pass --force" in line
    sys.argv = ["prog", "--domain", MINIMAL, "--state", str(state), "--out", str(out), "--force"]
    try:
        main()
    finally:
        sys.argv = before
    assert json.loads(out.read_text())["state"] != saved["state"]


def test_a_label_checkpoint_of_other_content_is_labelled_again(minimal, tmp_path):
    from learning.gnn.dataset import label_states

    ck = tmp_path / "labels.partial.json"
    s = minimal.init
    header = {**identity(minimal), "layout": "grid"}
    ck.write_text(json.dumps({**header, "labels": {str(s): [-7.0, [1, 1, 1], 0.0]}}))
    assert label_states([s], tiny_cfg(), ck, progress=False)[s][0] == -7.0  # its own: resumed
    ck.write_text(json.dumps({**header, "domain_sha256": OTHER_DIGEST, "labels": {str(s): [-7.0, [1, 1, 1], 0.0]}}))
    assert label_states([s], tiny_cfg(), ck, progress=False)[s][0] >= 0  # another's: labelled again
    assert json.loads(ck.read_text())["domain_sha256"] == identity(minimal)["domain_sha256"]


def test_reused_labels_must_be_of_this_layout_and_content(minimal, tmp_path):
    from learning.gnn.dataset import known_labels

    other = tmp_path / "other"
    other.mkdir()
    labels = {"labels": {str(minimal.init): [5.0, [5, 5, 5], 0.1]}}
    (other / "labels.partial.json").write_text(json.dumps({**labels, "domain": "restaurant", "layout": "two-room"}))
    with pytest.raises(DomainError) as e:
        known_labels([other], minimal)
    assert one_line(e) == (
        f"{other}/labels.partial.json: labels of restaurant two-room, not of minimal grid; "
        f"leave out --reuse-labels {other}"
    )
    (other / "labels.partial.json").write_text(json.dumps(labels))  # an early checkpoint: its meta.json says
    (other / "meta.json").write_text(json.dumps({**identity(minimal), "layout": "grid", "domain_sha256": OTHER_DIGEST}))
    with pytest.raises(DomainError, match=r"meta.json: labels made from other content of domain 'minimal'"):
        known_labels([other], minimal)
    (other / "meta.json").write_text(json.dumps({**identity(minimal), "layout": "grid"}))
    assert known_labels([other], minimal) == {minimal.init: (5.0, [5, 5, 5], 0.1)}


def test_a_prepared_stream_cache_of_another_stream_or_content_is_planned_again(minimal, tmp_path):
    from learning.gnn.dataset import cached_plans

    header = {"layout": "grid", "seed": 1, **identity(minimal), "min_clause_cost": 200, "plan_time_limit": 120.0}
    cache = tmp_path / "prepared-rollout-0.json"
    rows = [{"task": "deliver(b)", "clause": None, "plan": []}]
    cache.write_text(json.dumps({**header, "tasks": rows}))
    assert cached_plans(cache, header, minimal) == rows
    assert cached_plans(cache, {**header, "seed": 2}, minimal) == []
    cache.write_text(json.dumps({"layout": "grid", "seed": 1, "tasks": rows}))  # an early cache
    assert cached_plans(cache, header, minimal) == rows
    cache.write_text(json.dumps({**header, "domain_sha256": OTHER_DIGEST, "tasks": rows}))
    assert cached_plans(cache, header, minimal) == []
    cache.write_text("[]")
    with pytest.raises(DomainError, match="corrupt prepared-stream cache"):
        cached_plans(cache, header, minimal)
