"""Every command builds its parser with `planning.cli.parser`, which declares each shared option once."""

import re
import sys
from pathlib import Path

import pytest

from planning import cli
from planning.domain.compiler import compile_domain

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("planning", "oracles", "learning", "experiments", "examples")
CLI = ROOT / "planning" / "cli.py"


def sources() -> list[Path]:
    return sorted(p for package in PACKAGES for p in (ROOT / package).rglob("*.py"))


def mains() -> list[Path]:
    return [p for p in sources() if 'if __name__ == "__main__"' in p.read_text()]


def name(p: Path) -> str:
    return str(p.relative_to(ROOT))


def test_the_mains_are_found():
    found = {name(p) for p in mains()}
    assert {
        "experiments/evaluate.py",
        "oracles/myopic.py",
        "planning/world/domain_check.py",
        "examples/maskable_ppo_minimal.py",
    } <= found
    assert len(found) >= 20


@pytest.mark.parametrize("path", mains(), ids=name)
def test_every_main_builds_its_parser_with_cli_parser(path):
    text = path.read_text()
    assert "ArgumentParser(" not in text, f"{name(path)} builds its own argparse.ArgumentParser"
    assert "cli.parser(" in text, f"{name(path)} does not build its parser with planning.cli.parser"


def declared(flag: str) -> list[str]:
    """The modules (and planning/cli.py) that declare `flag` with add_argument."""
    pattern = re.compile(r"add_argument\(\s*f?[\"']" + re.escape(flag) + r"[\"']")
    return [name(p) for p in sources() if pattern.search(p.read_text())]


@pytest.mark.parametrize(
    "flag", ["--no-progress", "--domain", "--layout", "--sequences", "--sequence", "--ray", "--out"]
)
def test_a_shared_option_is_declared_only_in_cli(flag):
    assert declared(flag) == ["planning/cli.py"], flag


def test_the_declaration_scan_sees_a_declaration():
    assert "oracles/command.py" in declared("--failure-protocol")
    assert "experiments/evaluate.py" in declared("--agent")


def test_the_default_domain_is_spelled_once():
    spelled = [name(p) for p in sources() if '"domains/restaurant"' in p.read_text()]
    assert spelled == ["planning/cli.py"]
    assert cli.DEFAULT_DOMAIN == "domains/restaurant"
    assert compile_domain.__defaults__[0] == cli.DEFAULT_DOMAIN


def test_shared_defaults():
    p = cli.parser("t", sequences=True, sequence=True, seed=True, progress=True, workers=True)
    args = vars(p.parse_args([]))
    assert args == {
        "domain": "domains/restaurant",
        "layout": None,
        "sequences": "0-9",
        "sequence": 0,
        "seed": 0,
        "out": None,
        "no_progress": False,
        "workers": 1,
        "ray": False,
    }
    args = p.parse_args(
        [
            "--domain",
            "domains/minimal",
            "--layout",
            "grid",
            "--sequences",
            "1,3",
            "--sequence",
            "4",
            "--seed",
            "7",
            "--no-progress",
            "--workers",
            "3",
            "--ray",
        ]
    )
    assert (args.domain, args.layout, args.sequences, args.sequence, args.seed) == (
        "domains/minimal",
        "grid",
        "1,3",
        4,
        7,
    )
    assert (args.no_progress, args.workers, args.ray) == (True, 3, True)


def test_only_the_options_asked_for(capsys):
    assert set(vars(cli.parser("t").parse_args([]))) == {"domain", "layout", "out"}
    assert set(vars(cli.parser("t", domain=False, layout=False, out=None).parse_args([]))) == set()
    assert set(vars(cli.parser("t", layout=False, progress=True).parse_args([]))) == {"domain", "out", "no_progress"}
    with pytest.raises(SystemExit) as e:
        cli.parser("t", domain=False).parse_args(["--domain", "x"])
    assert e.value.code == 2
    assert "unrecognized arguments: --domain x" in capsys.readouterr().err


def test_helps_reword_only_the_help():
    p = cli.parser(
        "t",
        seed=True,
        helps={"layout": "check only this layout (default: every layout)", "seed": "seed of the rollout"},
    )
    text = p.format_help()
    assert "check only this layout (default: every layout)" in text and "seed of the rollout" in text
    assert "the folder's first" not in text and "random seed" not in text
    assert vars(p.parse_args([])) == {"domain": "domains/restaurant", "layout": None, "seed": 0, "out": None}
    assert "results folder to write" in cli.parser("t", out="folder").format_help()
    assert "results JSON to write" in cli.parser("t").format_help()


def test_out_is_checked_as_it_is_parsed(tmp_path):
    (tmp_path / "file").write_text("")
    assert cli.parser("t").parse_args(["--out", str(tmp_path / "r.json")]).out == str(tmp_path / "r.json")
    with pytest.raises(Exception, match="is a directory"):
        cli.parser("t").parse_args(["--out", str(tmp_path)])
    with pytest.raises(Exception, match="is a file"):
        cli.parser("t", out="folder").parse_args(["--out", str(tmp_path / "file")])


def test_peek_reads_its_flags_and_leaves_the_rest(monkeypatch):
    monkeypatch.setattr(sys, "argv", ["evaluate", "--layout", "two-room", "--agent", "random", "--seed", "3"])
    known = cli.peek(agent=None, list_agents=False)
    assert vars(known) == {"agent": "random", "list_agents": False}
    monkeypatch.setattr(sys, "argv", ["evaluate", "--list-agents"])
    assert vars(cli.peek(agent=None, list_agents=False)) == {"agent": None, "list_agents": True}
