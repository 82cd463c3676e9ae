"""Where the tests look for real data sets: relative to the checkout or where the environment
says, never an absolute path; a missing data set skips its tests with the path looked at."""

import re
from pathlib import Path

import pytest

import helpers

REPO = Path(__file__).resolve().parents[2]


def test_without_the_variable_the_data_are_looked_for_beside_the_checkout(monkeypatch):
    monkeypatch.delenv(helpers.REALDATA_ENV, raising=False)
    assert helpers.realdata("soton3storey") == REPO.parent / "shared" / "realdata" / "soton3storey"


def test_the_variable_names_the_folder_and_a_missing_set_says_where_it_was_looked_for(monkeypatch, tmp_path):
    monkeypatch.setenv(helpers.REALDATA_ENV, str(tmp_path))
    assert helpers.realdata("frame") == tmp_path / "frame"
    reason = helpers.realdata_skip_reason("frame")
    assert reason and str(tmp_path / "frame") in reason and helpers.REALDATA_ENV in reason
    (tmp_path / "frame").mkdir()
    assert helpers.realdata_skip_reason("frame") is None


def test_no_test_names_an_absolute_real_data_path():
    """Every real data set is reached through `helpers.realdata` (the test files name none)."""
    absolute = re.compile(r"""["'](/|[A-Za-z]:\\)[^"']*realdata""")
    offenders = [str(p.relative_to(REPO)) for p in (REPO / "tests").rglob("*.py")
                 if absolute.search(p.read_text(encoding="utf-8"))]
    assert not offenders, offenders


@pytest.mark.realdata("no-such-data-set")
def test_a_marked_test_without_its_data_is_skipped():
    pytest.fail("conftest.py should have skipped this test: its data set does not exist")
