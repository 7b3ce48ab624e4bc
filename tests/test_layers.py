"""The layering: planning -> oracles -> learning -> experiments; no module imports from a layer above its own."""

import ast
from pathlib import Path

import pytest

LAYERS = ["planning", "oracles", "learning", "experiments"]
ROOT = Path(__file__).resolve().parents[1]


def imported_packages(path: Path) -> set[str]:
    """Top-level packages a module imports, anywhere in it (function-level imports included)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            out.add(node.module.split(".")[0])
    return out


def modules():
    return sorted(p for layer in LAYERS for p in (ROOT / layer).rglob("*.py"))


@pytest.mark.parametrize("path", modules(), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_import_runs_up_the_layers(path):
    own = LAYERS.index(path.relative_to(ROOT).parts[0])
    above = {layer for layer in LAYERS[own + 1 :]} & imported_packages(path)
    assert not above, f"{path.relative_to(ROOT)} imports from a layer above it: {sorted(above)}"


def test_the_check_sees_a_violation(tmp_path):
    bad = tmp_path / "m.py"
    bad.write_text("def f():\n    from experiments.registry import AGENTS\n")
    assert "experiments" in imported_packages(bad)


# Inside planning/, bottom to top: a module imports only from its own level or below.
PLANNING_LEVELS = [
    {"__init__", "errors", "atomic", "cache", "cli", "parallel", "states", "value", "native"},
    {"domain"},
    {"external"},
    {"heuristics"},
    {"search"},
    {"world"},
]


def planning_level(name: str) -> int:
    return next(i for i, level in enumerate(PLANNING_LEVELS) if name in level)


def imported_parts(path: Path, package: str = "planning", root: Path = ROOT) -> set[str]:
    """The parts of `package` (a subpackage or a top-level module) a module imports, anywhere in it; a
    relative import that stays inside the module's subpackage is of its own part."""
    out = set()
    inside = path.relative_to(root / package).parts if (root / package) in path.parents else None
    own = inside[0].removesuffix(".py") if inside else None
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out |= {a.name.split(".")[1] for a in node.names if a.name.startswith(package + ".")}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            parts = node.module.split(".")
            if parts[0] == package:
                out |= {parts[1]} if len(parts) > 1 else {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level and own is not None:
            depth = len(inside) - 1  # folders between the package and the module
            if node.level <= depth:
                out.add(own)
            elif node.module:
                out.add(node.module.split(".")[0])
            else:
                out |= {a.name for a in node.names}
    return out


@pytest.mark.parametrize("path", sorted((ROOT / "planning").rglob("*.py")), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_import_runs_up_inside_planning(path):
    part = path.relative_to(ROOT / "planning").parts[0].removesuffix(".py")
    own = planning_level(part)
    above = {p for p in imported_parts(path) if planning_level(p) > own}
    assert not above, f"{path.relative_to(ROOT)} ({part}) imports from above it inside planning/: {sorted(above)}"


def test_the_planning_order_names_every_part():
    parts = {p.relative_to(ROOT / "planning").parts[0].removesuffix(".py") for p in (ROOT / "planning").rglob("*.py")}
    assert parts <= set().union(*PLANNING_LEVELS), parts - set().union(*PLANNING_LEVELS)


def test_the_planning_check_sees_a_violation(tmp_path):
    bad = tmp_path / "m.py"
    bad.write_text("def f():\n    from planning.search.optimal import optimal_plan\n    from planning import world\n")
    assert imported_parts(bad) == {"search", "world"}


# Inside learning/, bottom to top: the shared basics, the Gymnasium environment, the Q-learner, the GNN,
# the values (the registry, the exact value, the ranking), the agents, then the commands.
LEARNING_LEVELS = [
    {"__init__", "encoding", "reward", "plain", "device"},
    {"gym_env"},
    {"q"},
    {"gnn"},
    {"values"},
    {"agents"},
    {"dqn", "gnn_dataset", "gnn_train", "export", "capacity"},
]


def learning_level(name: str) -> int:
    return next(i for i, level in enumerate(LEARNING_LEVELS) if name in level)


@pytest.mark.parametrize("path", sorted((ROOT / "learning").rglob("*.py")), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_import_runs_up_inside_learning(path):
    part = path.relative_to(ROOT / "learning").parts[0].removesuffix(".py")
    own = learning_level(part)
    above = {p for p in imported_parts(path, "learning") if learning_level(p) > own}
    assert not above, f"{path.relative_to(ROOT)} ({part}) imports from above it inside learning/: {sorted(above)}"


def test_the_learning_order_names_every_part():
    parts = {p.relative_to(ROOT / "learning").parts[0].removesuffix(".py") for p in (ROOT / "learning").rglob("*.py")}
    assert parts == set().union(*LEARNING_LEVELS), parts ^ set().union(*LEARNING_LEVELS)


def test_the_learning_check_sees_a_violation(tmp_path):
    """A module of q/ that reaches up to the agents, relatively and by name, besides its own part."""
    bad = tmp_path / "learning" / "q" / "m.py"
    bad.parent.mkdir(parents=True)
    bad.write_text(
        "from ..agents.greedy import checkpoint_run_name\nfrom .targets import td_targets\n"
        "def f():\n    from learning.gnn.model import load_gnn\n    import learning.values\n"
    )
    assert imported_parts(bad, "learning", tmp_path) == {"agents", "q", "gnn", "values"}
