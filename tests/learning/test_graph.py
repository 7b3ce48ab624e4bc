"""The graph encoding of a state: nodes, features and edges derived from the compiled model."""

import numpy as np
import pytest

from learning.gnn.graph import EMBEDDING_DIM, GraphEncoder
from planning.domain.roles import agent_predicates


def fake_embed(names):
    """A deterministic stand-in for MiniLM: each name's own vector, so no model is loaded."""
    return np.array([np.random.default_rng(abs(hash(n)) % 2**32).normal(size=EMBEDDING_DIM) for n in names])


@pytest.fixture(scope="module")
def enc(three_room):
    return GraphEncoder(three_room, embed=fake_embed)


def edges(enc, state):
    """The set of (source, relation, target) names, one direction per fact."""
    _, index, attr = enc.arrays(state)
    half = index.shape[1] // 2
    return {
        (enc.node_names[s], enc.relation_names[a.argmax()], enc.node_names[t])
        for (s, t), a in zip(index.T[:half], attr[:half])
    }


def test_start_state_nodes(enc):
    assert enc.node_names == [
        "robot",
        "kitchen",
        "serving",
        "storage",
        "countertop",
        "coffeemachine",
        "dishwasher",
        "shelf",
        "servingtable",
        "fountain",
        "pantry",
        "cup_0",
        "cup_1",
        "water_fountain",
        "water_machine",
        "apple_0",
        "bowl_0",
        "knife_0",
        "jar_0",
        "plate_0",
    ]
    assert enc.node_types.count("agent") == 1 and enc.node_types.count("room") == 3
    assert enc.node_types.count("location") == 7 and enc.node_types.count("object") == 9
    assert enc.num_features == 384 + 4 + 2 + 9 + 13
    assert enc.relation_names == ["robot-at", "holding", "at", "in", "brews-at", "room"]


def test_start_state_edges(enc, three_room):
    got = edges(enc, three_room.init)
    rooms = {
        ("countertop", "kitchen"),
        ("coffeemachine", "kitchen"),
        ("dishwasher", "kitchen"),
        ("shelf", "kitchen"),
        ("servingtable", "serving"),
        ("fountain", "serving"),
        ("pantry", "storage"),
    }
    at = {
        "cup_0": "countertop",
        "cup_1": "dishwasher",
        "water_fountain": "fountain",
        "water_machine": "coffeemachine",
        "apple_0": "countertop",
        "bowl_0": "countertop",
        "knife_0": "countertop",
        "jar_0": "pantry",
        "plate_0": "servingtable",
    }
    want = (
        {(l, "room", r) for l, r in rooms}
        | {(o, "at", l) for o, l in at.items()}
        | {("robot", "robot-at", "countertop"), ("water_machine", "brews-at", "coffeemachine")}
    )
    assert got == want
    data = enc.encode(three_room.init)
    assert data.x.shape == (20, enc.num_features) and data.edge_index.shape == (2, 2 * len(want))
    # every edge is there in both directions
    pairs = set(map(tuple, data.edge_index.T.tolist()))
    assert all((t, s) in pairs for s, t in pairs)


def test_start_state_features(enc, three_room):
    x, _, _ = enc.arrays(three_room.init)
    col = {n: i for i, n in enumerate(enc.feature_names)}
    node = {n: i for i, n in enumerate(enc.node_names)}
    assert x[node["cup_1"], col["fact:dirty"]] == 1 and x[node["cup_0"], col["fact:dirty"]] == 0
    assert x[node["robot"], col["fact:hand-free"]] == 1
    assert x[node["dishwasher"], col["fact:washing-place"]] == 1
    assert x[node["jar_0"], col["is:jar"]] == 1 and x[node["jar_0"], col["is:fillable"]] == 1
    assert x[node["cup_0"], col["is:jar"]] == 0
    assert tuple(x[node["jar_0"], col["x"] : col["y"] + 1]) == (10, 10)  # at the pantry
    assert tuple(x[node["serving"], col["x"] : col["y"] + 1]) == (1.5, 1.0)  # mean of its locations
    assert x[node["robot"], col["type:agent"]] == 1 and x[node["kitchen"], col["type:room"]] == 1


def test_held_object_hangs_on_the_agent(enc, three_room):
    m = three_room
    s = m.apply(m.apply(m.init, m.action("pick(cup_0, countertop)")), m.action("move(countertop, fountain)"))
    got = edges(enc, s)
    assert ("robot", "holding", "cup_0") in got and not any(e[0] == "cup_0" and e[1] == "at" for e in got)
    x, _, _ = enc.arrays(s)
    col = {n: i for i, n in enumerate(enc.feature_names)}
    cup = enc.node_names.index("cup_0")
    assert x[cup, col["fact:holding"]] == 1
    assert tuple(x[cup, col["x"] : col["y"] + 1]) == (2, 1)  # with the robot, at the fountain


def test_agent_predicates(three_room):
    assert agent_predicates(three_room) == {"robot-at", "hand-free", "holding"}


@pytest.mark.slow
def test_minilm_embeddings_offline(three_room, tmp_path):
    """The packaged all-MiniLM-L6-v2 loads without network; embeddings are unit vectors, cached by name."""
    from learning.gnn.graph import sentence_embeddings

    cache = tmp_path / "emb.json"
    e = sentence_embeddings(["cup_0", "robot"], cache=cache)
    assert e.shape == (2, EMBEDDING_DIM) and np.allclose(np.linalg.norm(e, axis=1), 1, atol=1e-4)
    assert cache.is_file() and np.allclose(sentence_embeddings(["robot"], cache=cache)[0], e[1])
