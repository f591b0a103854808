"""Python's simulate and step against the stroke (docs/emulator.md#end-stops): a reference
outside the cylinder is refused, as the command line refuses it, and a linear prediction that
leaves the cylinder warns, with the core's one stroke check."""

import warnings

import numpy as np
import pytest

import pumpcyl


def test_simulate_refuses_a_reference_outside_the_stroke():
    rig = pumpcyl.Rig()
    t = np.arange(0, 3, 0.01)
    for far in (7000.0, 500.0, 0.0, -5.0):
        with pytest.raises(pumpcyl.PumpcylError, match="stroke"):
            pumpcyl.simulate(rig, t, np.where(t < 0.5, 345.0, far))


def test_a_prediction_beyond_the_stroke_warns_and_one_inside_does_not():
    rig = pumpcyl.Rig()
    t = np.arange(0, 3, 0.01)
    # 345 -> 499 mm: the article's loop overshoots the 154 mm step by half, past 500 mm
    with pytest.warns(UserWarning, match=r"reaches 57\d\.\d mm, outside the stroke 0…500 mm"):
        s = pumpcyl.simulate(rig, t, np.where(t < 0.5, 345.0, 499.0))
    assert 570.0 < s.signals.x_mm.max() < 585.0
    with pytest.warns(UserWarning, match=r"reaches -\d+\.\d mm, outside the stroke"):
        pumpcyl.step(rig, step_mm=-340.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pumpcyl.simulate(rig, t, np.where(t < 0.5, 345.0, 350.0))
        pumpcyl.step(rig, step_mm=5.0)
