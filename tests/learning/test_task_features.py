"""The learner's task encoding with the goal atoms (`task_features = "arguments+goal"`), on the blockworld, whose
tasks name a job of a library and so show nothing of their goal in their arguments."""

import shutil
from pathlib import Path

import numpy as np
import pytest

from learning.encoding import Encoding
from learning.q.checkpoints import network_payload, read_checkpoint, save_checkpoint
from learning.q.network import build_network
from learning.q.training import Config, Trainer, domain_defaults
from learning.q.value import value_function
from planning.domain.compiler import compile_domain
from planning.errors import DomainError

BLOCKWORLD = str(Path(__file__).resolve().parents[2] / "domains" / "blockworld")


@pytest.fixture(scope="module")
def grid7():
    return compile_domain(BLOCKWORLD, "grid7x7")


def goal_atoms(enc: Encoding, task) -> set[str]:
    """The atoms whose goal columns are set for a task, by name (the columns after the arguments' one-hots)."""
    plain = Encoding(enc.model, "arguments").task_feat.shape[1]
    cols = np.flatnonzero(enc.task_feat[task.index, plain:])
    n, used = enc.model.n_atoms, []
    pos_neg = np.zeros((len(enc.model.tasks), 2 * n), dtype=bool)
    for t in enc.model.tasks:
        for b in t.bindings:
            pos_neg[t.index, [a for a in range(n) if (b.pos >> a) & 1]] = True
            pos_neg[t.index, [n + a for a in range(n) if (b.neg >> a) & 1]] = True
    used = np.flatnonzero(pos_neg.any(axis=0))
    names = []
    for c in used[cols]:
        atom = "(" + " ".join(enc.model.atoms[c % n]) + ")"
        names.append(atom if c < n else f"(not {atom})")
    return set(names)


def test_the_goal_atoms_are_the_jobs_wanted_placements(grid7):
    enc = Encoding(grid7, "arguments+goal")
    plain = Encoding(grid7, "arguments")
    assert enc.task_feat.shape[1] > plain.task_feat.shape[1]
    assert np.array_equal(enc.task_feat[:, : plain.task_feat.shape[1]], plain.task_feat)  # the thesis's part kept
    one = grid7.tasks.get("one-block(d_orange)")
    two = grid7.tasks.get("two-blocks(a_green_e_cyan)")
    assert goal_atoms(enc, one) == {"(at d orange)", "(hand-free)"}
    assert goal_atoms(enc, two) == {"(at a green)", "(at e cyan)", "(hand-free)"}
    # every task's goal columns differ: the encoding tells the twenty jobs apart by what they want
    goal = enc.task_feat[:, plain.task_feat.shape[1] :]
    assert len({row.tobytes() for row in goal}) == len(grid7.tasks)
    assert enc.obs_dim == grid7.n_atoms + enc.task_feat.shape[1]
    assert enc.signature()["task_features"] == "arguments+goal" and "task_features" not in plain.signature()


def test_the_domain_names_its_encoding_and_a_checkpoint_keeps_its_own(grid7, tmp_path):
    """domain.toml [training] task_features is the default of the trainer and of Encoding(model) (the bundled
    blockworld names the goal-object view, the restaurant nothing: the thesis's); a checkpoint is read with the
    encoding it was trained with, whatever the domain says now."""
    assert Encoding(grid7).task_features == "arguments+objects"
    assert domain_defaults(grid7, "myopic")["task_features"] == "arguments+objects"
    restaurant = compile_domain("domains/restaurant", "two-room")
    assert Encoding(restaurant).task_features == "arguments" and "task_features" not in domain_defaults(
        restaurant, "myopic"
    )
    folder = tmp_path / "blockworld"
    shutil.copytree(BLOCKWORLD, folder, ignore=shutil.ignore_patterns("sequences"))
    toml = folder / "domain.toml"
    toml.write_text(toml.read_text().replace('task_features = "arguments+objects"', 'task_features = "arguments+goal"'))
    goal = compile_domain(folder, "grid7x7")
    assert domain_defaults(goal, "myopic")["task_features"] == "arguments+goal"
    assert Encoding(goal).task_features == "arguments+goal"
    for features in ("arguments", "arguments+goal", "arguments+objects"):
        enc = Encoding(grid7, features)
        payload = network_payload(build_network(enc, 16), enc, {"config": {"task_features": features}})
        path = save_checkpoint(tmp_path / f"{features}.pt", payload)
        vf = value_function(read_checkpoint(path), goal, path)
        assert vf.enc.task_features == features and vf.enc.obs_dim == enc.obs_dim
    with pytest.raises(DomainError, match="task_features: 'goal' is not one of arguments, arguments"):
        Encoding(grid7, "goal")
    bad = shutil.copytree(folder, tmp_path / "bad")  # another folder: compiled models are cached by folder
    (bad / "domain.toml").write_text(toml.read_text().replace('"arguments+goal"', '"goals"'))
    with pytest.raises(DomainError, match=r"domain\.toml: \[training\] task_features 'goals' is not one of"):
        Encoding(compile_domain(bad, "grid7x7"))


def test_a_run_resumes_only_under_its_own_task_encoding(grid7, tmp_path):
    values = {
        **domain_defaults(grid7, "myopic"),
        "task_features": "arguments+goal",
        "steps": 30,
        "learning_starts": 10,
        "demo_tasks": 2,
    }
    values.update(eval_every=10**9, checkpoint_every=30, log_every=30, goal_reward=30.0, hidden=16)
    cfg = Config(domain=BLOCKWORLD, layout="grid7x7", horizon="myopic", out=str(tmp_path / "run"), **values)
    Trainer(cfg, progress=False).train()
    other = Config(**{**cfg.__dict__, "task_features": "arguments"})
    with pytest.raises(DomainError, match="was trained with task_features='arguments\\+goal', not 'arguments'"):
        Trainer(other, progress=False).resume(tmp_path / "run" / "last.pt")
