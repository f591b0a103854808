#!/usr/bin/env python3
"""The headline numbers of Gøytil, Hansen & Tvilde, "Effective Bulk Modulus in Low-Pressure
Pump-Controlled Hydraulic Cylinders", Actuators 2025, 14(8), 366, with `import pumpcyl`.

1. Margins of the article's rig (§2.3.3, §3.3): GM 6.5 dB, PM 34 deg.
2. The bulk modulus identified from the records in data/article/ (§2.4; emulated records
   with a known truth of 165 bar, see data/article/README.md): about 165 bar.
3. The gas fraction at the records' 4.4 bar mean pressure and beta_e at 1 and 10 bar with the
   margins there (§3.1): 37.8 and 370 bar in the article.
4. The largest Kp meeting PM 34 deg and GM 6 dB (§2.2): about 25.

Run: python examples/article.py   (after `pip install ./python`)
"""

import pathlib

import pumpcyl

ARTICLE = pathlib.Path(__file__).resolve().parents[1] / "data" / "article"
P_MEAN_BAR = 4.4  # mean chamber pressure of the identification records (the article §3.1)


def main(progress=True):
    rig = pumpcyl.Rig()
    m = pumpcyl.margins(rig)
    print(f"default rig: GM {m.gain_margin_db:.2f} dB at {m.phase_crossover_hz:.2f} Hz, "
          f"PM {m.phase_margin_deg:.1f} deg at {m.gain_crossover_hz:.2f} Hz  (article: 6.5 dB, 34 deg)")

    r = pumpcyl.identify(str(ARTICLE / "identify.toml"), progress=progress)
    print(f"identified: beta {r.beta_bar:.1f} bar, b {r.viscous_friction_ns_per_m:.0f} N·s/m, "
          f"c12 {r.c12_m5_per_ns:.3g} m⁵/(N·s), cost {r.cost_mm2:.2e} mm2  (article: 165 bar, 1.2e-10)")

    x = pumpcyl.gas_fraction(beta_bar=r.beta_bar, p_mean_bar=P_MEAN_BAR)
    betas = {p: pumpcyl.effective_beta(x, p) for p in (1.0, 10.0)}
    print(f"gas fraction X = {x:.4f}; beta_e(1 bar) = {betas[1.0]:.1f} bar, "
          f"beta_e(10 bar) = {betas[10.0]:.0f} bar  (article: 37.8 and 370 bar)")
    pressure_margins = {}
    for p, beta in betas.items():
        mp = pumpcyl.margins(rig.replace(beta_bar=beta))
        pressure_margins[p] = mp
        print(f"  at {p:>4.0f} bar: GM {mp.gain_margin_db:.2f} dB, PM {mp.phase_margin_deg:.1f} deg")

    d = pumpcyl.design(rig, target_pm_deg=34, target_gm_db=6)
    print(f"design: largest Kp for PM 34 deg and GM 6 dB = {d['kp_max']:.2f}  (article: 25)")
    return dict(margins=m, identification=r, gas_fraction=x, beta_e=betas,
                pressure_margins=pressure_margins, kp_max=d["kp_max"])


if __name__ == "__main__":
    main()
