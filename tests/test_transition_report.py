"""The report's "Transition search" section: what a feature step's search found."""

import warnings

import numpy as np
import pytest

from sklearn_ifog import make_compensation_pipeline
from sklearn_ifog.report import compensation_report
from sklearn_ifog.report._columns import RunColumns
from sklearn_ifog.report._sections import transitions_of

from _campaigns import small_glass_campaign  # isort: skip


@pytest.fixture(scope="module")
def campaign():
    return small_glass_campaign()


def _report(tmp_path, campaign, **params):
    X, y = campaign.data, np.asarray(campaign.target)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = make_compensation_pipeline(**params).fit(X, y)
        frame = campaign.frame
        columns = RunColumns(
            rate=frame["rate"],
            drift=model.predict(X),
            reference=frame["reference"],
            temperature=frame["temperature"],
            time=frame["time"],
            run=frame["run"],
        )
        result = compensation_report(tmp_path, columns, model=model, X=X)
    return model, result.paths["markdown"].read_text()


def test_a_searched_transition_is_reported_with_what_was_found(tmp_path, campaign):
    model, text = _report(tmp_path, campaign, transition="auto")
    found = model.steps[0][1].transition_
    assert found is not None
    assert transitions_of(model) == [(None, found)]
    section = text[text.index("### Transition search") :]
    row = next(line for line in section.splitlines() if line.startswith("| the model |"))
    cells = [cell.strip() for cell in row.strip("|").split("|")]
    assert cells[1] == found.shape
    assert float(cells[2]) == pytest.approx(found.centre, abs=1e-3)
    assert float(cells[3]) == pytest.approx(found.width)
    assert float(cells[4]) == pytest.approx(found.lag)
    assert float(cells[5]) == pytest.approx(found.held_out_gain, rel=1e-3)
    assert cells[7] == ("yes" if found.terms else "no")


def test_no_search_no_section(tmp_path, campaign):
    model, text = _report(tmp_path, campaign)
    assert model.steps[0][1].transition_ is None
    assert transitions_of(model) == []
    assert "Transition search" not in text
