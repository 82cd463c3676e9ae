"""The boxes of unmeasured mode entries (`vibupdate.inverse.formulation.blocks.natural_block`)."""

import numpy as np
from helpers import chain_model

from vibupdate.data.measured import Configuration, NaturalFrequency, ShapeInterval
from vibupdate.inverse.formulation.blocks import natural_block
from vibupdate.inverse.formulation.options import FormulationOptions
from vibupdate.inverse.formulation.scaling import scaling_of


def test_a_nominal_mode_near_a_node_at_the_shape_reference_keeps_bounded_boxes():
    """The measured shape's largest entry (its reference, y1) sits where the nominal mode is
    almost zero: the unmeasured entries' box is taken relative to the nominal mode's largest
    measured entry (y2 here), not to its value at y1 (it was 1.5e12 wide)."""
    model = chain_model(4, ["k1"])
    options = FormulationOptions()
    shape = ShapeInterval({"y1": (0.95, 1.05), "y2": (0.45, 0.55)})
    cfg = Configuration("C", model, (NaturalFrequency(10.0, shape=shape),))
    v0 = np.array([1e-12, 0.5, 1.0, 0.8])           # nominal mode, physical; y1 is DOF 0
    blk = natural_block(cfg, 0, v0, scaling_of(model, options), options)
    unmeasured = ~blk.measured
    np.testing.assert_allclose(blk.upper[unmeasured], options.shape_margin * 1.0 / 0.5)
    np.testing.assert_allclose(blk.lower[unmeasured], -options.shape_margin * 1.0 / 0.5)
    # where the reference entry is the nominal mode's largest measured one, as before
    v1 = np.array([1.0, 0.5, 2.0, 0.8])
    before = natural_block(cfg, 0, v1, scaling_of(model, options), options)
    np.testing.assert_allclose(before.upper[~before.measured], options.shape_margin * 2.0)
