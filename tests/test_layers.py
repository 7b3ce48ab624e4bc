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
    above = {layer for layer in LAYERS[own + 1:]} & imported_packages(path)
    assert not above, f"{path.relative_to(ROOT)} imports from a layer above it: {sorted(above)}"


def test_the_check_sees_a_violation(tmp_path):
    bad = tmp_path / "m.py"
    bad.write_text("def f():\n    from experiments.registry import AGENTS\n")
    assert "experiments" in imported_packages(bad)
