"""The report's text (`vibupdate.report.document`)."""

from vibupdate.io.results import MeshSensor, SolverRecord
from vibupdate.report.document import verification_markdown


def _solver(**polish):
    check = {"name": "fit", "passed": True, "severity": "error", "message": "every frequency within 1 %"}
    base = {"cost_start": 3.4381, "cost": 9.45e-20, "kept": True, "evaluations": 4, "message": "converged",
            "seconds": 10.5}
    return SolverRecord.from_dict({"status": "success", "message": "", "checks": [check], "verified": True,
                                   "polish": {**base, **polish}})


def test_the_verification_section_says_how_the_polish_worked():
    text = "\n".join(verification_markdown(_solver(rounds=4, reduced_evaluations=55)))
    assert "from 3.4381e+00 to 9.4500e-20 in 4 evaluations of the full model (4 rounds on a reduced model, " \
           "55 evaluations there; each round checked on the full model) and was kept" in text
    assert "**verified**" in text
    plain = "\n".join(verification_markdown(_solver(rounds=0, reduced_evaluations=0)))
    assert "in 4 evaluations of the full model and was kept" in plain and "rounds" not in plain
    older = "\n".join(verification_markdown(_solver()))          # a results file written before the rounds
    assert "in 4 evaluations of the full model and was kept" in older


def test_the_verification_section_says_when_the_polish_stopped_on_a_limit():
    said = "stopped on the limit of 5 evaluations of the full model, objective 0.01"
    text = "\n".join(verification_markdown(_solver(stopped_on="evaluations", message=said)))
    assert f"was kept (stopped on its evaluations limit: {said})" in text
    converged = "\n".join(verification_markdown(_solver(stopped_on="convergence")))
    assert "limit" not in converged


def test_the_sensor_map_shows_each_direction_and_a_dash_where_a_results_file_has_none():
    from types import SimpleNamespace

    from vibupdate.report.document import sensors_table
    from vibupdate.report.table import markdown

    run = SimpleNamespace(sensors=(MeshSensor.from_dict({"sensor": "d", "dof": "7:n1", "sign": -1.0, "distance_m": 0.01,
                                                         "direction": [-0.6, 0.0, -0.8]}),
                                   MeshSensor.from_dict({"sensor": "old", "dof": "7:x", "sign": 1.0, "distance_m": 0.0})))
    text = "\n".join(markdown(sensors_table(run)))
    assert "| sensor | DOF | sign | reads along (x, y, z) | distance [m] |" in text
    assert "| d | 7:n1 | - | (-0.6, 0, -0.8) | 0.01 |" in text and "| old | 7:x | + | - | 0 |" in text


def test_a_verdict_within_the_model_form_tolerances_claims_no_cause_it_did_not_prove():
    # data met only through the model-form tolerance: the model's form is one cause, a closer
    # fit the search's starts did not reach the other (exact data stuck in a local minimum)
    from types import SimpleNamespace

    from vibupdate.report.document import limited_text

    form = limited_text([SimpleNamespace(name="fit", limited_by="model_form")])
    assert "within the model-form tolerances only" in form and "(check fit)" in form
    assert "a closer fit exists that the search's starts did not reach" in form
    assert limited_text([SimpleNamespace(name="fit", limited_by="measurement")]).endswith(
        "every datum lies in its measurement interval")
    assert limited_text([SimpleNamespace(name="fit", limited_by="")]) == ""


def test_the_search_line_says_whether_uniqueness_was_searched_once():
    from types import SimpleNamespace

    from vibupdate.report.document import sought_text

    failed = SimpleNamespace(starts=(1, 2, 3), uniqueness=False, reason="uniqueness not searched: no answer verified")
    assert sought_text(failed) == "Starts tried: 3; uniqueness not searched: no answer verified."
    searched = SimpleNamespace(starts=(1,), uniqueness=True, reason="the nominal point and 2 random start(s) polished")
    assert sought_text(searched) == ("Starts tried: 1; uniqueness searched (the nominal point and 2 random start(s) "
                                     "polished).")
