"""Bad input: a one-line error naming the file or thing and the reason."""
import shutil
import subprocess
import sys

import pytest

from planning.domain.compiler import compile_source
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
    path.write_text(path.read_text().replace('{ bowls = 0.5, knives = 0.5 }', '{ bowls = 0.5, spoons = 0.5 }'))
    with pytest.raises(DomainError) as e:
        compile_folder(folder)
    assert one_line(e) == f"{path}: task wash: unknown object 'spoons' for ?k"


def test_task_argument_of_wrong_type(folder):
    path = folder / "domain.toml"
    path.write_text(path.read_text().replace('"?l" = ["servingtable"] }\n\n[tasks.make-coffee]',
                                             '"?l" = ["cup_0"] }\n\n[tasks.make-coffee]'))
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
    r = subprocess.run([sys.executable, "-m", "planning.domain.bench", "--domain", str(folder), "--layout", "attic"],
                       capture_output=True, text=True)
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and "unknown layout 'attic'" in r.stderr
