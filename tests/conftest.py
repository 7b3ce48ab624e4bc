import pytest

from planning.domain.compiler import compile_domain

RESTAURANT = "domains/restaurant"
MINIMAL = "domains/minimal"

GRID_STREAMS = """
[streams.alternate]
kind = "markov"
[streams.alternate.transitions]
clear = { deliver = 0.9, clear = 0.1 }
deliver = { clear = 0.5, deliver = 0.5 }

[streams.shift]
kind = "drift"
blend = "BLEND"
phases = [
  { from = 0, types = { clear = 1.0 } },
  { from = 10, types = { deliver = 1.0 } },
]
"""


def declare_grid_streams(folder, blend="step", extra=""):
    """Make a copy of the minimal domain folder draw both task types (clear 0.3, deliver 0.7) and declare two
    streams: `alternate` (Markov) and `shift` (drifting at task 10, `blend` "step" or "linear")."""
    toml = (folder / "domain.toml").read_text()
    toml = toml.replace("[tasks.clear]\nprobability = 0.0", "[tasks.clear]\nprobability = 0.3")
    toml = toml.replace("[tasks.deliver]\nprobability = 1.0", "[tasks.deliver]\nprobability = 0.7")
    (folder / "domain.toml").write_text(toml + GRID_STREAMS.replace("BLEND", blend) + extra)


@pytest.fixture(scope="session")
def two_room():
    return compile_domain(RESTAURANT, "two-room")


@pytest.fixture(scope="session")
def three_room():
    return compile_domain(RESTAURANT, "three-room")


@pytest.fixture(scope="session", params=["two-room", "three-room"])
def restaurant(request):
    return compile_domain(RESTAURANT, request.param)


@pytest.fixture(scope="session")
def minimal():
    return compile_domain(MINIMAL, "grid")


def run_plan(model, state: int, names: list[str]) -> tuple[int, int]:
    """(final state, total cost) of a plan given by ground action names."""
    cost = 0
    for name in names:
        a = model.action(name)
        state = model.apply(state, a)
        cost += model.action_cost[a]
    return state, cost


@pytest.fixture(scope="module")
def checkpoint(minimal, tmp_path_factory):
    """A tiny untrained Q-network checkpoint of the minimal grid (anticipatory, γ 0.99)."""
    from learning.encoding import Encoding
    from learning.q.checkpoints import network_payload, save_checkpoint
    from learning.q.network import build_network

    enc = Encoding(minimal)
    path = tmp_path_factory.mktemp("ckpt") / "rl-anticipatory-grid-seed0.pt"
    payload = network_payload(
        build_network(enc, 16), enc, {"step": 1, "config": {"gamma": 0.99, "horizon": "anticipatory"}}
    )
    return str(save_checkpoint(path, payload))


@pytest.fixture(scope="module")
def gnn(minimal, tmp_path_factory):
    """A tiny untrained GNN checkpoint with the minimal grid's node features."""
    from learning.gnn.graph import GraphEncoder
    from learning.gnn.model import GNNCostModel, save_gnn_checkpoint

    names = GraphEncoder(minimal).feature_names
    net = GNNCostModel(len(names), width=8)
    path = tmp_path_factory.mktemp("gnn") / "gnn-grid-seed0.pt"
    payload = {"model": net.state_dict(), "dims": net.dims, "feature_names": names, "layout": minimal.layout}
    return str(save_gnn_checkpoint(path, payload))


@pytest.fixture(scope="module")
def grid_folder(tmp_path_factory):
    """A copy of the minimal domain folder with two canonical 4-task sequences of its grid (a reset, clear(c),
    then deliveries): a real folder the evaluation command can read."""
    import shutil
    from pathlib import Path

    from planning.atomic import write_json
    from planning.world.sequences import generate

    folder = tmp_path_factory.mktemp("domains") / "tiny"
    shutil.copytree(Path(__file__).resolve().parent.parent / MINIMAL, folder)
    for rec in generate(compile_domain(folder, "grid"), count=2, length=4):
        write_json(folder / "sequences" / "grid" / f"seq-{rec['id']:02d}.json", rec)
    return folder
