import pytest

from planning.domain.compiler import compile_domain

RESTAURANT = "domains/restaurant"
MINIMAL = "domains/minimal"


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
