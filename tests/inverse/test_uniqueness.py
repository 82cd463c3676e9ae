"""The uniqueness search: the set of answers where the data leave directions undetermined,
and the cost of the probing polishes."""

import numpy as np
import pytest
from scipy.optimize import brentq

from helpers import chain_model
from vibupdate import Configuration, NaturalFrequency, modes
from vibupdate.inverse.minimum_change import valley_ends
from vibupdate.inverse.search import Search
from vibupdate.inverse.status import Verdict
from vibupdate.inverse.update import update


def _first(model, k1, k2):
    M, K = model.matrices_at([k1, k2])
    return float(modes(M, K)[0][0])


def test_fewer_data_than_parameters_give_not_unique_with_the_ends_of_the_set_of_answers():
    # two springs of a 2-mass chain from its first natural frequency alone: the springs that
    # give it form a curve; the answer returned is its point nearest the nominal model, and the
    # ends of the curve in each spring (computed here by root finding on the frequency) are the
    # other answers. Before, every start of the uniqueness search was moved to the same point
    # of the curve and the run said "verified".
    model = chain_model(2, ["k1", "k2"])
    truth = (1000.0, 1000.0)
    w1 = _first(model, *truth)
    result = update([Configuration("one mode", model, (NaturalFrequency(w1),))])
    assert result.success and result.verdict is Verdict.NOT_UNIQUE, result.message
    ends = {a.start: a.values for a in result.alternatives}
    for values in ends.values():   # each fits the datum exactly
        assert _first(model, values["k1"], values["k2"]) == pytest.approx(w1, rel=1e-9)
    lo = {p.name: p.lower for p in model.parameters}
    hi = {p.name: p.upper for p in model.parameters}
    # w1 grows with both springs: k1 is lowest where k2 is highest, and the other way round
    def k1_at(k2):   # the k1 that gives w1 with this k2, held to its bounds
        f = lambda k: _first(model, k, k2) - w1   # noqa: E731
        return lo["k1"] if f(lo["k1"]) > 0 else hi["k1"] if f(hi["k1"]) < 0 else brentq(f, lo["k1"], hi["k1"],
                                                                                          xtol=1e-10)

    k1_low, k1_high = k1_at(hi["k2"]), k1_at(lo["k2"])
    assert lo["k1"] < k1_low < k1_high < hi["k1"]    # interior ends: k2 is on its bounds there
    assert ends["valley end (lowest k1)"]["k1"] == pytest.approx(k1_low, rel=1e-6)
    assert ends["valley end (highest k1)"]["k1"] == pytest.approx(k1_high, rel=1e-6)
    assert any(s.start == "valley ends" and s.status == "same data" for s in result.sought.starts)
    # switched off, the same run says verified, as the search did before
    off = update([Configuration("one mode", model, (NaturalFrequency(w1),))], search=Search(valley_ends=False))
    assert off.verdict is Verdict.VERIFIED and not off.alternatives


def test_valley_ends_are_empty_where_the_data_determine_every_parameter():
    model = chain_model(2, ["k1", "k2"])
    M, K = model.matrices_at([1100.0, 900.0])
    w = modes(M, K)[0]
    cfg = Configuration("two modes", model, tuple(NaturalFrequency(x) for x in w))
    assert valley_ends([cfg], model.normalized([1100.0, 900.0])) == []
