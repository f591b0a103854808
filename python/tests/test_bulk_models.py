"""The family of beta(p) models (docs/bulk-modulus.md#a-family-of-models) in
`pumpcyl bulk-modulus --json`'s `models`: each model's beta_e on a grid of 1-300 bar equals its
equation implemented here independently to 1e-9, with the gas fraction pumpcyl fitted, and that
fit gives back the reading (the article's 165 bar at 4.4 bar, and another) to 1e-9."""

import math

import pytest

from conftest import pumpcyl_json

P0 = 1.01325  # bar, atmospheric


def entrained(x, p_gauge, n, beta_oil):
    p = p_gauge + P0
    v_g = x * (P0 / p) ** (1.0 / n)
    v_l = (1.0 - x) * math.exp(-(p - P0) / beta_oil)
    return (v_l + v_g) / (v_l / beta_oil + v_g / (n * p))


def beta(model, x, p, beta_oil):
    """beta_e (bar) of `model` (the JSON object) with gas fraction x at gauge pressure p (bar)."""
    name = model["model"]
    if name == "constant-gas-fraction":
        return 1.0 / (x / p + (1.0 - x) / beta_oil)
    if name == "constant-gas-fraction-absolute":
        return 1.0 / (x / (p + P0) + (1.0 - x) / beta_oil)
    if name == "entrained-air":
        return entrained(x, p, model["polytropic_index"], beta_oil)
    assert name == "entrained-air-dissolving", name
    p_crit = model["air_dissolution_pressure_bar"]
    free = min(max((p_crit - p) / p_crit, 0.0), 1.0)
    return entrained(x * free, p, model["polytropic_index"], beta_oil)


@pytest.mark.parametrize("reading", [(165.0, 4.4), (600.0, 12.0)])
def test_each_model_is_its_equation_and_holds_the_reading(reading):
    beta_bar, p_mean = reading
    doc = pumpcyl_json("bulk-modulus", [], "--beta-bar", str(beta_bar), "--p-mean-bar", str(p_mean),
                       "--from-bar", "1", "--to-bar", "300", "--points", "300")
    oil = doc["beta_oil_bar"]
    family = doc["models"]
    assert [m["model"] for m in family["models"]] == [
        "constant-gas-fraction", "constant-gas-fraction-absolute", "entrained-air",
        "entrained-air-dissolving"]
    for m in family["models"]:
        x = m["gas_fraction"]
        assert abs(beta(m, x, p_mean, oil) - beta_bar) <= 1e-9 * beta_bar, (m, reading)
        for p, got in zip(family["p_bar"], m["beta_bar"]):
            want = beta(m, x, p, oil)
            assert abs(got - want) <= 1e-9 * want, (m["model"], p, got, want)
    # the article's model is the one the table and the margins use
    article = family["models"][0]
    assert article["gas_fraction"] == doc["gas_fraction"]
    assert article["beta_bar"] == [row["beta_bar"] for row in doc["table"]]


@pytest.mark.parametrize("name", ["constant-gas-fraction-absolute", "entrained-air",
                                  "entrained-air-dissolving"])
def test_the_table_and_its_margins_follow_the_model_asked_for(name):
    """`bulk-modulus --model NAME`: the gas fraction is that model's fit, the table's beta_e its
    equation's, and each row's margins those of `pumpcyl margins` with that beta."""
    options = {"entrained-air": ["--polytropic-index", "1.2"],
               "entrained-air-dissolving": ["--polytropic-index", "1.2",
                                            "--air-dissolution-pressure-bar", "25"]}
    doc = pumpcyl_json("bulk-modulus", [], "--model", name, *options.get(name, []))
    model = doc["model"]
    assert model["model"] == name
    oil, x = doc["beta_oil_bar"], doc["gas_fraction"]
    if "polytropic_index" in model:
        assert model["polytropic_index"] == 1.2
    for row in doc["table"]:
        want = beta(model, x, row["p_bar"], oil)
        assert abs(row["beta_bar"] - want) <= 1e-9 * want
    assert abs(beta(model, x, 4.4, oil) - 165.0) <= 1e-9 * 165.0
    low = doc["table"][0]
    m = pumpcyl_json("margins", [f"beta_bar={low['beta_bar']!r}"])
    assert low["gain_margin_db"] == m["gain_margin_db"] and low["closed_loop_stable"] == m["closed_loop_stable"]


def fit(model, beta_bar, p, beta_oil):
    """The gas fraction of `model` through (beta_bar, p), by bisection here (beta falls as X
    rises)."""
    lo, hi = 0.0, 1.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if beta(model, mid, p, beta_oil) > beta_bar:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


# a rig that is not the article's: an 80/45 mm cylinder, 2 t, its own beta, one mass
OWN_RIG = ["piston_diameter_mm=80", "rod_diameter_mm=45", "mass_kg=2000", "mass_by_position=[]",
           "beta_bar=400"]


@pytest.mark.parametrize("model", [
    {"model": "constant-gas-fraction-absolute"},
    {"model": "entrained-air", "polytropic_index": 1.3},
    {"model": "entrained-air-dissolving", "polytropic_index": 1.1,
     "air_dissolution_pressure_bar": 20.0},
])
def test_the_rig_key_sets_the_model_of_every_command(model, tmp_path):
    """`bulk_modulus_model` (with its parameters) in the rig: `bulk-modulus` tables it without
    --model, `design --p-mean-bar` takes beta_e at each pressure from it through the rig's
    beta at its anchor, and the emulator's gas fraction is its fit there."""
    import re
    import subprocess

    from conftest import pumpcyl_binary
    sets = OWN_RIG + [f"bulk_modulus_model={model['model']}"] + [
        f"{k}={v}" for k, v in model.items() if k != "model"]
    # the rig as a file, so the emulator runs it as it is (not the emulated article rig's
    # set-point with these keys over it)
    args = [pumpcyl_binary(), "rig"]
    for s in sets:
        args += ["--set", s]
    rig = tmp_path / "own.toml"
    rig.write_text(subprocess.run(args, capture_output=True, text=True, check=True).stdout)
    bulk = pumpcyl_json("bulk-modulus", [], "--rig", str(rig))
    assert bulk["model"] == model
    oil = bulk["beta_oil_bar"]
    anchor = bulk["gas_fraction_from"]["p_mean_bar"]
    x = fit(model, 400.0, anchor, oil)
    assert abs(bulk["gas_fraction"] - x) <= 1e-9 * x
    design = pumpcyl_json("design", [], "--rig", str(rig), "--p-mean-bar", "1.5",
                          "--p-mean-bar", "12")
    assert design["targets"]["p_beta_bar"] == anchor
    assert design["targets"]["bulk_model"]["model"] == model["model"]
    for c in design["conditions"]:
        want = beta(model, x, c["p_mean_bar"], oil)
        assert abs(c["beta_bar"] - want) <= 1e-9 * want, (c, want)
    args = [pumpcyl_binary(), "emulate", "--experiment", "step", "--duration-s", "1",
            "--rig", str(rig), "--out", str(tmp_path / "step.csv")]
    out = subprocess.run(args, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    said = re.search(r"gas fraction X = ([0-9.]+).*under the ([a-z-]+)", out.stdout + out.stderr)
    assert said, out.stdout + out.stderr
    assert abs(float(said.group(1)) - x) < 1e-5 and said.group(2) == model["model"]


@pytest.mark.parametrize("sets, key", [
    (["polytropic_index=1.2"], "polytropic_index"),
    (["bulk_modulus_model=entrained-air", "air_dissolution_pressure_bar=20"],
     "air_dissolution_pressure_bar"),
    (["bulk_modulus_model=entrained-air", "polytropic_index=3"], "polytropic_index"),
    (["bulk_modulus_model=bubbles"], "bulk_modulus_model"),
])
def test_a_parameter_the_model_does_not_have_is_refused(sets, key):
    import subprocess

    from conftest import pumpcyl_binary
    args = [pumpcyl_binary(), "margins"]
    for s in sets:
        args += ["--set", s]
    out = subprocess.run(args, capture_output=True, text=True, timeout=60)
    assert out.returncode != 0 and out.stdout == ""
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and key in lines[0], out.stderr


def test_select_reads_the_gas_fraction_and_beta_under_the_rigs_model():
    """`select` with the rig's `bulk_modulus_model`: its reference gas fraction is that model's
    fit to the article's 165 bar at 4.4 bar (a factor 2 either way), and every DPM candidate's
    beta range is the model's beta at its mean pressure for the range's ends."""
    model = {"model": "entrained-air", "polytropic_index": 1.4}
    doc = pumpcyl_json("select", ["rig.bulk_modulus_model=entrained-air",
                                  "rig.polytropic_index=1.4"], timeout=600)
    lo, x, hi = doc["gas_fraction"]
    want = fit(model, 165.0, 4.4, 17000.0)
    assert abs(x - want) <= 1e-9 * want and lo == x / 2 and hi == 2 * x
    dpm = [o for o in doc["options"] if o["circuit"] == "low_pressure"]
    assert dpm
    for o in dpm:
        p = o["mean_pressure_bar"]
        soft, stiff = o["beta_e_bar"]
        assert abs(soft - beta(model, hi, p, 17000.0)) <= 1e-9 * soft
        assert abs(stiff - beta(model, lo, p, 17000.0)) <= 1e-9 * stiff
