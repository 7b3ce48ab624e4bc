import pytest

from tests.blockworld_copy import copy_blockworld


@pytest.fixture(scope="module")
def bw(tmp_path_factory):
    """(work folder, domain folder): a copy of the blockworld folder with one canonical sequence of four tasks,
    one per test module (the blockworld tool tests, tests/blockworld_copy.py)."""
    work = tmp_path_factory.mktemp("bw")
    return work, copy_blockworld(work)
