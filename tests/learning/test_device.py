"""`--device` (`learning.device`): the checks every machine runs, the device-independent parts of the GPU path
on the CPU (the trainer's CPU copy of the online network, a value evaluated in torch), and, where CUDA is
there, the GPU path itself (skipped without it: CI has no GPU)."""

import subprocess
import sys

import numpy as np
import pytest
import torch

from learning.device import check_device
from learning.encoding import Encoding
from learning.q.inference import LiveGreedy
from learning.q.network import build_network
from learning.q.training import Trainer, train_runs
from learning.q.value import ValueFunction
from planning.errors import DomainError
from tests.learning.test_dqn import small_config
from tests.learning.test_seeds import walk_states

CUDA = torch.cuda.is_available()
needs_cuda = pytest.mark.skipif(not CUDA, reason="no CUDA device here")


def test_device_names_are_checked():
    assert check_device(None) is None
    assert check_device("cpu") == torch.device("cpu")
    with pytest.raises(DomainError, match="not a torch device"):
        check_device("gpu0")
    with pytest.raises(DomainError, match="only cpu and cuda"):
        check_device("meta")


@pytest.mark.skipif(CUDA, reason="a CUDA device is here")
def test_cuda_where_there_is_none_is_a_one_line_error(tmp_path):
    with pytest.raises(DomainError, match="'cuda'"):
        check_device("cuda")
    r = subprocess.run(
        [sys.executable, "-m", "learning.dqn", "--domain", "domains/minimal", "--horizon", "myopic"]
        + ["--steps", "10", "--device", "cuda", "--out", str(tmp_path / "run"), "--no-progress"],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "--device" in r.stderr
    assert not (tmp_path / "run" / "metrics.jsonl").exists()


def test_several_seeds_on_a_device_are_refused(minimal, tmp_path, monkeypatch):
    """Seeds trained together stay on the CPU (the check is patched to accept cuda here, so the rule is tested
    on a machine without a GPU too)."""
    import learning.device

    monkeypatch.setattr(learning.device, "check_device", lambda name: torch.device("cuda"))
    cfgs = [small_config(minimal, tmp_path / str(s), seed=s, steps=10) for s in (0, 1)]
    with pytest.raises(DomainError, match="CPU only"):
        train_runs(cfgs, progress=False, device="cuda")


def test_acting_through_a_cpu_copy_of_the_online_network_is_the_same_run(minimal, tmp_path):
    """The trainer of a GPU run acts and checkpoints through a CPU copy of the online weights refreshed after
    every update (`Trainer._cpu_copy`): on the CPU, a run made that way takes the same actions, fills the same
    replay memory and ends with the same weights as the plain run, and its checkpoint holds those weights."""
    runs = []
    for copy in (False, True):
        t = Trainer(small_config(minimal, tmp_path / str(copy), "anticipatory", steps=400, demo_tasks=20), False)
        if copy:
            t.actor = t._cpu_copy()
            t.greedy = LiveGreedy(t.actor)
            assert t.actor is not t.net and t.actor.encoder[0].weight.data_ptr() != t.net.encoder[0].weight.data_ptr()
        t.train()
        runs.append(t)
    plain, copied = runs
    n = len(plain.memory)
    for key in ("states", "actions", "rewards", "next_states", "kinds"):
        assert np.array_equal(getattr(plain.memory, key)[:n], getattr(copied.memory, key)[:n]), key
    for p, q, r in zip(plain.net.parameters(), copied.net.parameters(), copied.actor.parameters()):
        assert torch.equal(p, q) and torch.equal(q, r)
    from learning.q.checkpoints import read_checkpoint

    saved = read_checkpoint(tmp_path / "True" / "last.pt")["net"]
    assert all(torch.equal(saved[k], v) for k, v in copied.net.state_dict().items())


def test_a_value_evaluated_in_torch_equals_the_compiled_one(two_room):
    """`ValueFunction.to_device` (here torch's CPU kernels: the GPU path's arithmetic and batching) gives the
    numpy / C engine's q_max and V_AP to float32 rounding, under the layout's P and under another
    distribution; the compiled search then calls q_max (no native engine)."""
    enc = Encoding(two_room)
    torch.manual_seed(0)
    net = build_network(enc, 64).eval()
    states = list(dict.fromkeys(walk_states(two_room, 60, seed=2)))
    engine, torch_value = ValueFunction(net, enc), ValueFunction(net, enc).to_device("cpu")
    task = two_room.tasks.get("serve-water(servingtable)")
    assert np.allclose(torch_value.q_max(states, task), engine.q_max(states, task), atol=1e-4)
    assert np.allclose(torch_value.v_ap(states), engine.v_ap(states), atol=1e-4)
    p = np.zeros(len(two_room.tasks))
    p[enc.support[:3]] = [0.5, 0.25, 0.25]
    for v in (engine, torch_value):
        v.set_distribution(p)
    assert np.allclose(torch_value.v_ap(states), engine.v_ap(states), atol=1e-4)
    assert torch_value.native_q_max(task) is None


def test_rl_guided_on_a_device_says_so(minimal, checkpoint):
    from tests.learning.test_values import guided

    agent = guided("rl-guided", ["--checkpoint", str(checkpoint), "--device", "cpu"], minimal)
    assert agent.config["device"] == "cpu" and agent.run_name.endswith("-device-cpu")
    with pytest.raises(DomainError, match="CPU only"):
        guided("rl-guided", ["--value", "zero", "--device", "cpu"], minimal)


@needs_cuda
def test_a_run_trains_on_the_gpu_and_its_checkpoint_loads_on_the_cpu(minimal, tmp_path):
    t = train_runs([small_config(minimal, tmp_path, "anticipatory", steps=400, demo_tasks=20)], False, False, "cuda")[0]
    assert t.net.encoder[0].weight.device.type == "cuda" and t.actor is not t.net
    for p, q in zip(t.net.parameters(), t.actor.parameters()):
        assert torch.equal(p.cpu(), q)
    again = Trainer(small_config(minimal, tmp_path, "anticipatory", steps=400, demo_tasks=20), False)
    again.resume(tmp_path / "last.pt")
    assert all(torch.equal(p, q.cpu()) for p, q in zip(again.net.parameters(), t.net.parameters()))


@needs_cuda
def test_a_value_on_the_gpu_equals_the_compiled_one(two_room):
    enc = Encoding(two_room)
    net = build_network(enc, 64).eval()
    states = walk_states(two_room, 40, seed=3)
    engine, gpu = ValueFunction(net, enc), ValueFunction(net, enc).to_device("cuda")
    assert np.allclose(gpu.v_ap(states), engine.v_ap(states), atol=1e-3)


def test_the_device_benchmark_times_both_trainers(minimal):
    """learning.q.bench --device: the same trainer on the device and on the CPU (here both the CPU: a ratio
    near 1, and both really ran their updates)."""
    from learning.q.bench import device_profile

    r = device_profile("domains/minimal", "grid", "myopic", 60, 0, "cpu")
    assert r["device"] == "cpu" and r["updates"] == 60
    assert r["cpu_updates_per_s"] > 0 and r["device_updates_per_s"] > 0 and 0.2 < r["ratio"] < 5
