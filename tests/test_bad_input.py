"""Bad input: a one-line error naming the file or thing and the reason."""

import json
import os
import pickle
import shutil
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest
import torch

from planning import cli
from planning.domain.compiler import _compile_cached, compile_source
from planning.domain.folder import read_domain
from planning.errors import DomainError


@pytest.fixture
def folder(tmp_path):
    dst = tmp_path / "restaurant"
    shutil.copytree("domains/restaurant", dst)
    return dst


def compile_folder(path, layout="two-room"):
    return compile_source(read_domain(path, layout))


def one_line(e) -> str:
    text = str(e.value)
    assert "\n" not in text
    return text


def test_malformed_pddl(folder):
    path = folder / "domain.pddl"
    path.write_text(path.read_text().replace("(:action move", "(:action move (((", 1))
    with pytest.raises(DomainError) as e:
        compile_folder(folder)
    assert one_line(e).startswith(f"{path}: cannot parse PDDL domain")


def test_undefined_move_cost(folder):
    path = folder / "two-room.pddl"
    path.write_text(path.read_text().replace("(= (move-cost shelf fountain) 200)", ""))
    with pytest.raises(DomainError) as e:
        compile_folder(folder)
    assert one_line(e) == f"{path}: undefined cost (move-cost shelf fountain) for action move(shelf, fountain)"


def test_task_naming_unknown_object(folder):
    path = folder / "domain.toml"
    path.write_text(path.read_text().replace("{ bowls = 0.5, knives = 0.5 }", "{ bowls = 0.5, spoons = 0.5 }"))
    with pytest.raises(DomainError) as e:
        compile_folder(folder)
    assert one_line(e) == f"{path}: task wash: unknown object 'spoons' for ?k"


def test_task_argument_of_wrong_type(folder):
    path = folder / "domain.toml"
    path.write_text(
        path.read_text().replace(
            '"?l" = ["servingtable"] }\n\n[tasks.make-coffee]', '"?l" = ["cup_0"] }\n\n[tasks.make-coffee]'
        )
    )
    with pytest.raises(DomainError) as e:
        compile_folder(folder)
    assert one_line(e) == f"{path}: task serve-water: object 'cup_0' is not of type location for ?l"


def test_unknown_layout_and_missing_folder(tmp_path):
    with pytest.raises(DomainError, match="unknown layout 'attic'"):
        read_domain("domains/restaurant", "attic")
    with pytest.raises(DomainError, match="no such domain folder"):
        read_domain(tmp_path / "nowhere", "two-room")


def test_probabilities_must_sum_to_one(folder):
    path = folder / "domain.toml"
    path.write_text(path.read_text().replace("probability = 0.25", "probability = 0.35"))
    with pytest.raises(DomainError, match="task type probabilities sum to 1.1, not 1"):
        compile_folder(folder)


def test_reset_naming_unknown_atom(folder):
    path = folder / "domain.toml"
    path.write_text(path.read_text().replace('"(dirty bowl_0)"', '"(dirty bowl_9)"'))
    with pytest.raises(DomainError, match=r"unknown object 'bowl_9' in \(dirty bowl_9\)"):
        compile_folder(folder)


def test_unsatisfiable_task_is_refused(folder):
    path = folder / "tasks.pddl"
    text = path.read_text().replace("(and (at ?c ?l) (has-water ?c))", "(and (at ?c ?l) (has-water ?c) (in ?c ?c))")
    path.write_text(text)
    with pytest.raises(DomainError, match=r"task serve-water\(servingtable\) can never be satisfied"):
        compile_folder(folder)


def test_command_line_exits_with_one_line(folder):
    r = subprocess.run(
        [sys.executable, "-m", "planning.external.simulator_bench", "--domain", str(folder), "--layout", "attic"],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and "unknown layout 'attic'" in r.stderr


# ---- every command's bad input, in-process: exit 2, one line naming the thing, finished files untouched ----

RESULTS = "results/myopic-oracle-internal-two-room.json"  # a finished run of `--agent myopic-oracle --planner internal`


class CreatesFile:
    """A pickle whose loading would create a file: what a hostile checkpoint does on a weights_only=False load."""

    def __init__(self, path):
        self.path = str(path)

    def __reduce__(self):
        return (open, (self.path, "w"))


@pytest.fixture(scope="module")
def w(tmp_path_factory):
    """One domain copy and one folder of files for the whole module (each case puts back what it edits)."""
    t = tmp_path_factory.mktemp("bad")
    d = t / "restaurant"
    shutil.copytree("domains/restaurant", d)
    finished = t / "finished.json"
    shutil.copy(RESULTS, finished)
    (t / "plain-file").write_text("not a folder\n")
    marker = t / "pwned"
    torch.save({"net": CreatesFile(marker), "dims": {}}, t / "hostile.pt")
    with open(t / "hostile-bare.pt", "wb") as f:
        pickle.dump({"net": CreatesFile(marker), "dims": {}}, f)
    (t / "truncated.pt").write_bytes(Path("checkpoints/rl-myopic-two-room-seed0.pt").read_bytes()[:5000])
    torch.save({"weights": torch.zeros(3)}, t / "foreign.pt")
    states = {
        "two-places.json": '["(robot-at shelf)", "(robot-at fountain)"]',
        "nowhere.json": "[]",
        "unbalanced.json": '["(robot-at shelf"]',
        "malformed.json": '["(robot-at shelf)"',
        "unknown-atom.json": '["(robot-at attic)"]',
        "no-init.pddl": "(define (problem p) (:domain d))",
    }
    for name, text in states.items():
        (t / name).write_text(text)
    return SimpleNamespace(t=t, d=d, finished=finished, marker=marker)


def snapshot(folder: Path) -> dict:
    return {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}


def fails(w, main, argv, expect: str, edits=(), capsys=None) -> str:
    """Run `main` as its command would (cli.run, sys.argv) with `edits` made to the domain copy; the
    run must exit 2 with one error line containing `expect`, leave every file it found as it was, and
    leave nothing of its own behind (no results, partial or temporary file)."""
    fmt = lambda a: str(a).format(D=w.d, T=w.t)
    saved = []
    for rel, old, new in edits:
        path = w.d / rel
        text = path.read_text()
        saved.append((path, text))
        assert old in text, (rel, old)
        path.write_text(text.replace(old, new, 1))
    before = snapshot(w.t)
    _compile_cached.cache_clear()
    argv_before = sys.argv
    sys.argv = ["prog", *map(fmt, argv)]
    try:
        with pytest.raises(SystemExit) as e:
            cli.run(main)
    finally:
        sys.argv = argv_before
        for path, text in reversed(saved):
            path.write_text(text)
        _compile_cached.cache_clear()
    err = capsys.readouterr().err
    lines = [line for line in err.replace("\r", "\n").splitlines() if line.strip()]
    assert e.value.code == 2, err
    assert "Traceback" not in err and lines and lines[-1].startswith("error: "), err
    assert err.rstrip("\n").splitlines()[-1] == lines[-1], err  # the error has a line of its own
    assert fmt(expect) in lines[-1], lines[-1]
    assert "(error msg: None)" not in lines[-1]
    assert snapshot(w.t) == before  # finished files untouched, nothing new
    assert not w.marker.exists()  # nothing of a hostile file ran
    return lines[-1]


def evaluate_main():
    from experiments.evaluate import main

    return main


def labelling_main():
    from oracles.labelling import main

    return main


def sequences_main():
    from planning.world.sequences import main

    return main


TOML, PROBLEM, DOMAIN, TASKS = "domain.toml", "two-room.pddl", "domain.pddl", "tasks.pddl"

# (case, edits of the domain copy, arguments of oracles.labelling, what the error line says)
DOMAIN_CASES = [
    ("malformed PDDL", [(DOMAIN, "(:action move", "(:action move (((")], "{D}/domain.pddl: cannot parse PDDL domain"),
    (
        "undefined cost",
        [(PROBLEM, "(= (move-cost shelf fountain) 200)", "")],
        "{D}/two-room.pddl: undefined cost (move-cost shelf fountain)",
    ),
    (
        "unknown predicate in :init",
        [(PROBLEM, "(:init", "(:init (flying shelf)")],
        '{D}/two-room.pddl: cannot parse PDDL problem: Undefined element "flying"',
    ),
    ("unknown predicate in a task", [(TASKS, "(has-water ?c)", "(has-wine ?c)")], 'Undefined element "has-wine"'),
    (
        "unknown object in a task",
        [(TOML, "{ bowls = 0.5, knives = 0.5 }", "{ bowls = 0.5, spoons = 0.5 }")],
        "{D}/domain.toml: task wash: unknown object 'spoons' for ?k",
    ),
    ("broken TOML", [(TOML, "[tasks.wash]", "[tasks.wash")], "{D}/domain.toml: malformed TOML"),
    (
        "negative task probability summing to 1",
        [
            (TOML, "probability = 0.05", "probability = -0.05"),
            (TOML, "probability = 0.05", "probability = 0.10"),
            (TOML, "probability = 0.05", "probability = 0.10"),
        ],
        "{D}/domain.toml: task clear: probability is -0.05, not between 0 and 1",
    ),
    (
        "task probability not a number",
        [(TOML, "probability = 0.25", 'probability = "high"')],
        "task serve-water: probability is 'high', not a number",
    ),
    (
        "negative argument probability",
        [(TOML, "{ bowls = 0.5, knives = 0.5 }", "{ bowls = 1.5, knives = -0.5 }")],
        "task wash: probability of bowls for ?k is 1.5, not between 0 and 1",
    ),
    (
        "reset probabilities 1.4, -0.4",
        [(TOML, "probabilities = [0.6, 0.4]", "probabilities = [1.4, -0.4]")],
        "{D}/domain.toml: [[reset]] entry 1: probability 1 is 1.4, not between 0 and 1",
    ),
    (
        "reset probabilities not matching the choices",
        [(TOML, "probabilities = [0.6, 0.4]", "probabilities = [1.0]")],
        "[[reset]] entry 1: probabilities must match choices",
    ),
    ("reset atom of an unknown object", [(TOML, '"(dirty bowl_0)"', '"(dirty bowl_9)"')], "unknown object 'bowl_9'"),
    (
        "reset atom with an unbalanced parenthesis",
        [(TOML, '"(dirty bowl_0)"', '"(dirty bowl_0"')],
        "{D}/domain.toml: not a ground atom like (at cup_0 shelf): '(dirty bowl_0'",
    ),
    (
        "task probabilities summing to 1.1",
        [(TOML, "probability = 0.25", "probability = 0.35")],
        "task type probabilities sum to 1.1, not 1",
    ),
    (
        "a task that can never be satisfied",
        [(TASKS, "(and (at ?c ?l) (has-water ?c))", "(and (at ?c ?l) (has-water ?c) (in ?c ?c))")],
        "task serve-water(servingtable) can never be satisfied",
    ),
    (
        "missing problem file",
        [(TOML, 'problem = "two-room.pddl"', 'problem = "nowhere.pddl"')],
        "{D}/nowhere.pddl: missing",
    ),
]


@pytest.mark.parametrize("case, edits, expect", DOMAIN_CASES, ids=[c[0] for c in DOMAIN_CASES])
def test_bad_domain_folder(w, capsys, case, edits, expect):
    fails(w, labelling_main(), ["--domain", "{D}", "--layout", "two-room"], expect, edits, capsys)


# (case, command, arguments, what the error line says); {T}/finished.json is a finished run of the
# myopic oracle (internal planner) that none of these may touch.
EVAL = ["--agent", "myopic-oracle", "--planner", "internal", "--layout", "two-room"]
GREEDY = [
    "--agent",
    "rl-greedy",
    "--layout",
    "two-room",
    "--sequences",
    "0",
    "--out",
    "{T}/greedy.json",
    "--checkpoint",
]
CLI_CASES = [
    ("unknown layout", labelling_main, ["--layout", "attic"], "unknown layout 'attic'"),
    ("missing domain folder", labelling_main, ["--domain", "{T}/nowhere"], "{T}/nowhere: no such domain folder"),
    (
        "backwards sequence range",
        evaluate_main,
        EVAL + ["--sequences", "5-2", "--out", "{T}/finished.json"],
        "--sequences: '5-2' is an empty range",
    ),
    (
        "malformed sequence list",
        evaluate_main,
        EVAL + ["--sequences", "a-b", "--out", "{T}/finished.json"],
        "--sequences: 'a-b' is not a list like 0-9 or 1,3,6",
    ),
    (
        "unknown sequence id",
        evaluate_main,
        EVAL + ["--sequences", "42", "--out", "{T}/finished.json"],
        "no sequence with id [42]",
    ),
    (
        "K = 0",
        evaluate_main,
        ["--agent", "clairvoyant", "--K", "0", "--out", "{T}/finished.json"],
        "--K: must be at least 1, not 0",
    ),
    (
        "K = -2",
        evaluate_main,
        ["--agent", "clairvoyant", "--K", "-2", "--out", "{T}/finished.json"],
        "--K: must be at least 1, not -2",
    ),
    (
        "negative myopic time limit",
        evaluate_main,
        EVAL + ["--time-limit", "-1", "--out", "{T}/finished.json"],
        "--time-limit: must be positive, not -1.0",
    ),
    (
        "zero clairvoyant time limit",
        evaluate_main,
        ["--agent", "clairvoyant", "--time-limit", "0"],
        "--time-limit: must be positive, not 0.0",
    ),
    ("negative labelling time limit", labelling_main, ["--time-limit", "-5"], "--time-limit: must be positive"),
    ("unknown agent", evaluate_main, ["--agent", "nosuch"], "--agent: unknown agent 'nosuch'"),
    (
        "--out is a directory",
        evaluate_main,
        EVAL + ["--sequences", "0", "--out", "{T}"],
        "{T}: is a directory, not a file to write",
    ),
    (
        "--out under a regular file",
        evaluate_main,
        EVAL + ["--sequences", "0", "--out", "{T}/plain-file/r.json"],
        "{T}/plain-file/r.json: cannot be written: {T}/plain-file is not a directory",
    ),
    (
        "labelling --out under a regular file",
        labelling_main,
        ["--out", "{T}/plain-file/c.json"],
        "cannot be written: {T}/plain-file is not a directory",
    ),
    (
        "impossible state: the robot in two places",
        labelling_main,
        ["--state", "{T}/two-places.json"],
        "{T}/two-places.json: an impossible state: (robot-at shelf) and (robot-at fountain) never hold together",
    ),
    (
        "unsolvable state: the robot nowhere",
        labelling_main,
        ["--state", "{T}/nowhere.json"],
        "{T}/nowhere.json: task serve-water(servingtable) cannot be completed from this state",
    ),
    (
        "state atom with an unbalanced parenthesis",
        labelling_main,
        ["--state", "{T}/unbalanced.json"],
        "{T}/unbalanced.json: not a ground atom",
    ),
    ("malformed state JSON", labelling_main, ["--state", "{T}/malformed.json"], "{T}/malformed.json: malformed JSON"),
    (
        "unknown state atom",
        labelling_main,
        ["--state", "{T}/unknown-atom.json"],
        "{T}/unknown-atom.json: (robot-at attic) is not a reachable fluent atom",
    ),
    ("state file missing", labelling_main, ["--state", "{T}/absent.json"], "{T}/absent.json: cannot read"),
    (
        "PDDL state without :init",
        labelling_main,
        ["--state", "{T}/no-init.pddl"],
        "{T}/no-init.pddl: neither a JSON list of atoms nor a PDDL problem",
    ),
    (
        "hostile checkpoint (torch.save)",
        evaluate_main,
        GREEDY + ["{T}/hostile.pt"],
        "{T}/hostile.pt: refused as a checkpoint: it would build Python objects (io.open)",
    ),
    (
        "hostile checkpoint (bare pickle)",
        evaluate_main,
        GREEDY + ["{T}/hostile-bare.pt"],
        "{T}/hostile-bare.pt: refused as a checkpoint: a bare pickle",
    ),
    (
        "truncated checkpoint",
        evaluate_main,
        GREEDY + ["{T}/truncated.pt"],
        "{T}/truncated.pt: not a readable checkpoint",
    ),
    ("missing checkpoint", evaluate_main, GREEDY + ["{T}/absent.pt"], "{T}/absent.pt: no such checkpoint"),
    ("foreign checkpoint", evaluate_main, GREEDY + ["{T}/foreign.pt"], "{T}/foreign.pt: not a Q-network checkpoint"),
    (
        "checkpoint of another layout",
        evaluate_main,
        GREEDY + ["checkpoints/rl-myopic-three-room-seed0.pt"],
        "trained for restaurant/three-room, not restaurant/two-room",
    ),
]


@pytest.mark.parametrize("case, main, argv, expect", CLI_CASES, ids=[c[0] for c in CLI_CASES])
def test_bad_command_line(w, capsys, case, main, argv, expect):
    fails(w, main(), argv, expect, capsys=capsys)


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes in a read-only folder")
def test_out_in_a_read_only_folder(w, capsys):
    ro = w.t / "read-only"
    ro.mkdir(exist_ok=True)
    ro.chmod(0o555)
    try:
        fails(
            w,
            evaluate_main(),
            EVAL + ["--sequences", "0", "--out", "{T}/read-only/r.json"],
            "{T}/read-only/r.json: cannot be written",
            capsys=capsys,
        )
    finally:
        ro.chmod(0o755)


def partial_of(w, rows) -> Path:
    """{T}/fresh.json.partial.json holding `rows` as sequence 0 of the internal myopic oracle's run."""
    from oracles.myopic import MyopicOracle

    path = w.t / "fresh.json.partial.json"
    path.write_text(
        json.dumps(
            {
                "agent": "myopic-oracle",
                "layout": "two-room",
                "config": MyopicOracle("internal").config,
                "wall_seconds": 1.0,
                "done": {"0": rows},
            }
        )
    )
    return path


def test_saved_results_that_are_not_what_they_claim(w, capsys):
    rows = [r for r in json.loads(Path(RESULTS).read_text())["per_task"] if r["sequence"] == 0]
    run = EVAL + ["--sequences", "0", "--out", "{T}/fresh.json"]
    try:
        partial_of(w, rows[:40])
        fails(
            w,
            evaluate_main(),
            run,
            "{T}/fresh.json.partial.json: corrupt partial results, sequence 0: 40 rows "
            "for its 50 tasks (cut short or edited by hand)",
            capsys=capsys,
        )
        partial_of(w, [rows[1], rows[0]] + rows[2:])
        fails(w, evaluate_main(), run, "corrupt partial results, sequence 0: row 0 is not task 0", capsys=capsys)
        partial_of(w, []).write_text("[1, 2]")
        fails(
            w,
            evaluate_main(),
            run,
            "{T}/fresh.json.partial.json: corrupt partial results (not a JSON object)",
            capsys=capsys,
        )
        partial_of(w, []).unlink()
        (w.t / "fresh.json").write_text('[{"agent": "myopic-oracle"}]')
        fails(w, evaluate_main(), run, "{T}/fresh.json: corrupt results (not a JSON object)", capsys=capsys)
        (w.t / "fresh.json").write_text('{"agent": "myopic-oracle", ')
        fails(w, evaluate_main(), run, "{T}/fresh.json: corrupt results", capsys=capsys)
        (w.t / "fresh.json").write_text(
            json.dumps({**json.loads(w.finished.read_text()), "config": {"planner": "internal", "time_limit": 5.0}})
        )
        fails(
            w,
            evaluate_main(),
            run,
            "a finished run with search None, not 'astar(pdb) by f-levels'; pass --force",
            capsys=capsys,
        )
    finally:
        for name in ("fresh.json", "fresh.json.partial.json"):
            (w.t / name).unlink(missing_ok=True)


def test_bad_sequence_files(w, capsys):
    path = w.d / "sequences" / "two-room" / "seq-00.json"
    text = path.read_text()
    try:
        path.write_text(text[:200])
        fails(
            w,
            sequences_main(),
            ["--domain", "{D}", "--layout", "two-room", "--check"],
            f"{path}: malformed sequence file (JSONDecodeError",
            capsys=capsys,
        )
        fails(
            w,
            evaluate_main(),
            EVAL + ["--domain", "{D}", "--sequences", "0", "--out", "{T}/fresh.json"],
            f"{path}: malformed sequence file",
            capsys=capsys,
        )
        path.write_text(text.replace("make-coffee(servingtable)", "fly(me)", 1))
        fails(
            w,
            evaluate_main(),
            EVAL + ["--domain", "{D}", "--sequences", "0", "--out", "{T}/fresh.json"],
            f"{path}: unknown task 'fly(me)'",
            capsys=capsys,
        )
    finally:
        path.write_text(text)


def test_trainer_refuses_a_hostile_last_checkpoint(w, capsys):
    """learning.dqn resumes from DIR/last.pt: a hostile one is refused and nothing of it runs."""
    from learning.dqn import main

    run = w.t / "run"
    run.mkdir(exist_ok=True)
    shutil.copy(w.t / "hostile.pt", run / "last.pt")
    fails(
        w,
        main,
        [
            "--domain",
            "domains/minimal",
            "--horizon",
            "myopic",
            "--demo-tasks",
            "2",
            "--no-progress",
            "--out",
            "{T}/run",
        ],
        f"{run}/last.pt: refused as a checkpoint",
        capsys=capsys,
    )
    fails(
        w,
        main,
        ["--domain", "domains/minimal", "--horizon", "myopic", "--out", "{T}/plain-file"],
        "{T}/plain-file: is a file, not a folder to write into",
        capsys=capsys,
    )


def test_an_error_ends_the_progress_bar_line_first(capsys):
    from tqdm import tqdm

    def main():
        bar = tqdm(total=10, desc="working")
        bar.update(3)
        raise DomainError("thing", "went wrong")

    with pytest.raises(SystemExit) as e:
        cli.run(main)
    err = capsys.readouterr().err
    assert e.value.code == 2 and err.endswith("\nerror: thing: went wrong\n") and "working" in err


def test_files_are_written_with_the_process_umask(tmp_path):
    from planning.atomic import write_json

    old = os.umask(0o027)
    try:
        write_json(tmp_path / "r.json", {})
    finally:
        os.umask(old)
    assert (tmp_path / "r.json").stat().st_mode & 0o777 == 0o640
