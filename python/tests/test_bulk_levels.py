"""β identified at several pressure levels and the family of β(p) models fitted to them
(docs/bulk-modulus.md#several-pressure-levels), on records emulated at three sum-pressure
set-points with a hidden model and gas fraction (emulated records, not measurements): the fit
names the hidden model or says the records cannot tell it from the others, the hidden model
stays plausible, its gas fraction's 95 % interval holds the truth, and the band of beta at
1 bar (parameter and model-form uncertainty) holds the true beta there."""

import json
import subprocess
import tomllib

import pytest

import pumpcyl
from conftest import pumpcyl_binary, pumpcyl_json
from test_bulk_models import beta

OIL = 17000.0


def run(*args):
    return subprocess.run([pumpcyl_binary(), *args], capture_output=True, text=True, check=True,
                          timeout=600).stdout


def write_rig(path, sets):
    args = ["rig"]
    for s in sets:
        args += ["--set", s]
    path.write_text(run(*args))


def emulate_level(tmp, i, sets, model, x, kp, mass, keys=""):
    """A rig at one set-point whose beta_bar is the hidden model's at its anchor (the emulator
    anchors its gas fraction there), two steps (Kp and 2/3 Kp) and a standstill record, and the
    experiment that identifies them (with the experiment keys `keys`)."""
    rig = tmp / f"rig{i}.toml"
    write_rig(rig, sets)
    anchor = pumpcyl_json("bulk-modulus", [], "--rig", str(rig))["gas_fraction_from"]["p_mean_bar"]
    write_rig(rig, sets + [f"beta_bar={beta(model, x, anchor, OIL)!r}"])
    datasets = ""
    for k, gain in enumerate([kp, round(2 * kp / 3, 3)]):
        record = tmp / f"step{i}_{k}.csv"
        run("emulate", "--experiment", "step", "--rig", str(rig), "--set", f"kp={gain}",
            "--out", str(record), "--seed", str(10 * i + k + 1))
        datasets += f'[[dataset]]\nfile = "{record.name}"\nkp = {gain}\nmass_kg = {mass}\nfit_end_s = 3.0\n'
    run("emulate", "--experiment", "standstill", "--rig", str(rig), "--out",
        str(tmp / f"still{i}.csv"), "--seed", str(10 * i + 9))
    exp = tmp / f"level{i}.toml"
    exp.write_text(f'rig = "{rig.name}"\n{keys}[standstill]\nrecord = "still{i}.csv"\n{datasets}')
    return exp

# an 80/45 mm cylinder, 12 t, longer lines, its own leakage: not the article's rig
OWN = ["mass_kg=12000", "piston_diameter_mm=80", "rod_diameter_mm=45", "mass_by_position=[]", "line_volume_1_dm3=0.3", "line_volume_2_dm3=0.3",
       "c12_m5_per_ns=8e-11", "k_pres_per_bar=0.15"]
ARTICLE = []  # the article's rig, its 10 593 kg at x0


@pytest.mark.parametrize("base, mass, model, x, named, refine", [
    # on the article's rig the three levels tell adiabatic entrained air from the rest
    (ARTICLE, 10593.0, {"model": "entrained-air", "polytropic_index": 1.4}, 0.12, True, True),
    # on a heavier rig the high levels bound beta loosely: the linear readings cannot tell, the
    # emulator run against the records can
    (OWN, 12000.0, {"model": "entrained-air", "polytropic_index": 1.4}, 0.12, False, True),
    # (its experiments keep their records out of the nonlinear refinement)
    (OWN, 12000.0, {"model": "constant-gas-fraction"}, 0.03, False, False),
])
def test_three_levels_find_the_hidden_model_and_bound_beta_at_1_bar(base, mass, model, x, named,
                                                                    refine, tmp_path):
    keys = [f"bulk_modulus_model={model['model']}"] + [
        f"{k}={v}" for k, v in model.items() if k != "model"]
    opt_out = "" if refine else "nonlinear_refinement = false\n"
    exps = [emulate_level(tmp_path, i, base + keys + ["kp=15", f"p_sum_ref_bar={s}"], model, x,
                          15, mass, opt_out)
            for i, s in enumerate([6, 12, 24])]
    args = []
    for e in exps:
        args += ["--level", str(e)]
    doc = pumpcyl_json("bulk-modulus", [], "--rig", str(tmp_path / "rig1.toml"), *args)
    levels = doc["levels"]
    fits = {json.dumps(f["model"], sort_keys=True): f for f in levels["fits"]}
    truth = fits[json.dumps(model, sort_keys=True)]
    standing = [f["model"] for f in levels["fits"] if f["plausible"]]
    # the hidden model is named, or stands among the models the records cannot tell apart
    assert levels["model"] == (model if named else None), levels["model"]
    assert model in standing, levels["fits"]
    lo, hi = truth["gas_fraction_interval"]
    assert lo <= x <= hi, (lo, x, hi)
    # the true beta at every level inside that level's interval
    for l in levels["identified"]:
        want = beta(model, x, l["p_mean_bar"], OIL)
        assert l["interval_bar"][0] <= want <= l["interval_bar"][1], (l, want)
    at_1 = next(b for b in levels["band"] if b["p_bar"] == 1.0)
    want = beta(model, x, 1.0, OIL)
    assert at_1["band_bar"][0] <= want <= at_1["band_bar"][1], (at_1, want)
    # the Akaike weights sum to 1 and order the fits
    assert abs(sum(f["akaike_weight"] for f in levels["fits"]) - 1.0) < 1e-12
    aic = [f["aic"] for f in levels["fits"]]
    assert aic == sorted(aic)
    check_nonlinear(levels, model, x, refine, tmp_path / "rig0.toml")


def check_nonlinear(levels, model, x, refine, rig):
    """The nonlinear refinement of the same records (docs/identification.md#nonlinear-refinement):
    every model refitted, the hidden one told, its X interval and each level's beta interval
    holding the truth, beta the model's equation at the refined X, and the rig's Coulomb
    friction, dead band and c12 (which the records were emulated with) found again."""
    nl = levels["nonlinear"]
    if not refine:
        assert nl is None
        return
    assert sorted(json.dumps(f["model"], sort_keys=True) for f in nl["fits"]) == sorted(
        json.dumps(f["model"], sort_keys=True) for f in levels["fits"])
    assert nl["model"] == model, [(f["model"], f["delta_aic"]) for f in nl["fits"]]
    best = nl["fits"][0]
    lo, hi = nl["gas_fraction_interval"]
    assert lo <= x <= hi, (lo, x, hi)
    assert lo == min(nl["profile_interval"][0], nl["datasets_interval"][0])
    assert hi == max(nl["profile_interval"][1], nl["datasets_interval"][1])
    assert len(nl["dataset_gas_fractions"]) == 6 and nl["identifiable"]
    for l in nl["levels"]:
        p = l["p_mean_bar"]
        assert abs(l["beta_bar"] - beta(model, best["refined"]["gas_fraction"], p, OIL)) <= 1e-9 * l["beta_bar"]
        assert l["interval_bar"][0] <= beta(model, x, p, OIL) <= l["interval_bar"][1], l
    for f in nl["fits"]:
        assert f["sse_mm2"] <= f["start_sse_mm2"]
    assert abs(sum(f["akaike_weight"] for f in nl["fits"]) - 1.0) < 1e-12
    deltas = [f["delta_aic"] for f in nl["fits"]]
    assert deltas == sorted(deltas) and deltas[0] == 0.0
    # the rig's own friction, dead band and leakage, within 20 % (absent, the Coulomb friction
    # is the article rig's 15 N scaled by the seals' diameters, docs/emulator.md)
    r = tomllib.loads(rig.read_text())
    seals = r["piston_diameter_mm"] + r["rod_diameter_mm"]
    truth = {"coulomb_friction_n": r.get("coulomb_friction_n", 15.0 * seals / 99.0),
             "pump_dead_band_rpm": r["pump_dead_band_rpm"], "c12_m5_per_ns": r["c12_m5_per_ns"]}
    for k, want in truth.items():
        assert abs(best["refined"][k] / want - 1.0) < 0.2, (k, best["refined"][k], want)


def test_advise_names_the_next_level_where_the_loop_is_stable(tmp_path):
    """`advise --level`: the experiment's own level and another; the next level advised is one
    where the first experiment's loop is stable under both models it separates (the margins
    shown are `pumpcyl margins`' with that beta), their beta there is each model's equation,
    and the Python call gives the same document."""
    model = {"model": "entrained-air", "polytropic_index": 1.4}
    keys = ["bulk_modulus_model=entrained-air", "polytropic_index=1.4", "kp=15"]
    exps = [emulate_level(tmp_path, i, keys + [f"p_sum_ref_bar={s}"], model, 0.12, 15, 10593.0)
            for i, s in enumerate([6, 12])]
    doc = pumpcyl_json("advise", [], str(exps[0]), "--level", str(exps[1]))
    levels = doc["pressure_levels"]
    assert [l["experiment"] for l in levels["identified"]] == [str(e) for e in exps]
    nxt = levels["next_level"]
    assert nxt is not None and levels["model"] is None
    fits = {json.dumps(f["model"], sort_keys=True): f for f in levels["fits"]}
    for m, b in zip(nxt["models"], nxt["beta_bar"]):
        f = fits[json.dumps(m, sort_keys=True)]
        assert f["plausible"]
        want = beta(m, f["gas_fraction"], nxt["p_mean_bar"], OIL)
        assert abs(b - want) <= 1e-9 * want
        rig = tmp_path / "rig0.toml"
        margins = pumpcyl_json("margins", [f"beta_bar={b!r}"], "--rig", str(rig))
        assert margins["closed_loop_stable"], (nxt, margins)
    # the Python call: the same fit (the wall-clock seconds aside)
    py = pumpcyl.advise(str(exps[0]), levels=[str(exps[1])])
    assert py["pressure_levels"]["next_level"] == nxt
    assert py["pressure_levels"]["fits"] == levels["fits"]


def test_the_refinement_refuses_records_off_one_rate(tmp_path):
    """An experiment that asks for the nonlinear refinement (`nonlinear_refinement = true`, one
    level) with a record whose samples are not at one rate: one line naming the experiment and
    the dataset, exit 1, nothing on stdout."""
    model = {"model": "constant-gas-fraction"}
    exp = emulate_level(tmp_path, 0, ["kp=15", "p_sum_ref_bar=12"], model, 0.0264, 15, 10593.0,
                        "nonlinear_refinement = true\n")
    record = tmp_path / "step0_0.csv"
    lines = record.read_text().splitlines()
    head = lines[0].split(",")
    t = head.index("time_s") if "time_s" in head else 0
    row = lines[50].split(",")
    row[t] = repr(float(row[t]) + 0.003)  # 0.3 of a 10 ms sample off
    lines[50] = ",".join(row)
    record.write_text("\n".join(lines) + "\n")
    out = subprocess.run([pumpcyl_binary(), "bulk-modulus", "--level", str(exp)],
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 1 and out.stdout == "", out
    err = out.stderr.strip()
    assert len(err.splitlines()) == 1, err
    assert str(exp) in err and "step0_0.csv" in err and "one rate" in err, err


def test_long_records_need_a_long_run_for_the_refinement(tmp_path):
    """Two levels of one 60 s step each: 2 × 6000 samples × 5 models is beyond the refinement's
    5·10^4 without --allow-long-run (docs/identification.md#nonlinear-refinement): one line that
    says so and how to keep the records out, exit 1, nothing on stdout."""
    exps = []
    for i, s in enumerate([6, 12]):
        rig = tmp_path / f"rig{i}.toml"
        write_rig(rig, ["kp=15", f"p_sum_ref_bar={s}"])
        run("emulate", "--experiment", "step", "--rig", str(rig), "--duration-s", "60",
            "--out", str(tmp_path / f"long{i}.csv"))
        run("emulate", "--experiment", "standstill", "--rig", str(rig), "--out",
            str(tmp_path / f"still{i}.csv"))
        exp = tmp_path / f"level{i}.toml"
        exp.write_text(f'rig = "{rig.name}"\n[standstill]\nrecord = "still{i}.csv"\n'
                       f'[[dataset]]\nfile = "long{i}.csv"\nkp = 15\nmass_kg = 10593\n'
                       'fit_end_s = 59.9\n')
        exps += ["--level", str(exp)]
    out = subprocess.run([pumpcyl_binary(), "bulk-modulus", *exps], capture_output=True,
                         text=True, timeout=600)
    assert out.returncode == 1 and out.stdout == "", out
    err = out.stderr.strip()
    assert len(err.splitlines()) == 1, err
    assert "nonlinear refinement" in err and "nonlinear_refinement = false" in err, err
    # 5991 samples (0 to 59.9 s at 100 Hz) per record, two records, five models
    assert "59910 units" in err and "--allow-long-run" in err, err
