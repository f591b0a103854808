//! Exact ZOH simulation against closed forms and independent integration (docs/simulation.md#exact-zero-order-hold).

use nalgebra::DMatrix;
use pumpcyl::lti::{Simulator, StateSpace, Zoh};
use pumpcyl::model::Plant;
use pumpcyl::rig::Rig;
use std::f64::consts::PI;

fn second_order(wn: f64, z: f64) -> StateSpace {
    StateSpace::new(
        DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -wn * wn, -2.0 * z * wn]),
        DMatrix::from_row_slice(2, 1, &[0.0, wn * wn]),
        DMatrix::from_row_slice(1, 2, &[1.0, 0.0]),
        DMatrix::zeros(1, 1),
    )
    .unwrap()
}

#[test]
fn second_order_step_matches_closed_form() {
    let (wn, z) = (7.0f64, 0.2f64);
    let wd = wn * (1.0 - z * z).sqrt();
    let sys = second_order(wn, z);
    let t: Vec<f64> = (0..=500).map(|k| k as f64 * 0.01).collect();
    let r = Simulator::new(&sys)
        .run(&t, &vec![1.0; t.len()], &[0.0, 0.0])
        .unwrap();
    let y = r.output(0);
    for (k, &tk) in t.iter().enumerate().skip(1) {
        let want = 1.0
            - (-z * wn * tk).exp() * ((wd * tk).cos() + z / (1.0 - z * z).sqrt() * (wd * tk).sin());
        let got = y[k];
        assert!(
            (got - want).abs() <= 1e-9 * want.abs().max(1e-3),
            "t={tk}: {got} vs {want}"
        );
    }
}

#[test]
fn first_order_sine_matches_closed_form_at_the_samples() {
    // ẏ = (u − y)/τ with a ZOH input u_k = sin(ω t_k): exact recursion
    // y_{k+1} = e^{−h/τ} y_k + (1 − e^{−h/τ}) u_k, checked against the closed-form sum
    let (tau, w, h) = (0.3f64, 2.0 * PI * 0.7, 0.01f64);
    let sys = StateSpace::new(
        DMatrix::from_element(1, 1, -1.0 / tau),
        DMatrix::from_element(1, 1, 1.0 / tau),
        DMatrix::from_element(1, 1, 1.0),
        DMatrix::zeros(1, 1),
    )
    .unwrap();
    let t: Vec<f64> = (0..=1000).map(|k| k as f64 * h).collect();
    let u: Vec<f64> = t.iter().map(|t| (w * t).sin()).collect();
    let r = Simulator::new(&sys).run(&t, &u, &[0.0]).unwrap();
    let y = r.output(0);
    let a = (-h / tau).exp();
    for k in (1..t.len()).step_by(37) {
        // y_k = Σ_{j<k} a^{k−1−j} (1 − a) u_j
        let want: f64 = (0..k)
            .map(|j| a.powi((k - 1 - j) as i32) * (1.0 - a) * u[j])
            .sum();
        assert!((y[k] - want).abs() <= 1e-9 * want.abs().max(1e-6), "k={k}");
    }
}

#[test]
fn continuous_sine_response_of_second_order_matches_closed_form_with_fine_hold() {
    // With a fine ZOH (h = 1e-4) a sine input approaches the continuous steady-state response
    // |G(jω)| sin(ωt + ∠G(jω)) shifted by half a step: check amplitude after transients die.
    let (wn, z, w) = (7.0f64, 0.5f64, 3.0f64);
    let sys = second_order(wn, z);
    let h = 1e-4;
    let t: Vec<f64> = (0..=100_000).map(|k| k as f64 * h).collect();
    let u: Vec<f64> = t.iter().map(|t| (w * t).sin()).collect();
    let r = Simulator::new(&sys).run(&t, &u, &[0.0, 0.0]).unwrap();
    let y = r.output(0);
    let g = num_complex::Complex64::new(wn * wn, 0.0)
        / num_complex::Complex64::new(wn * wn - w * w, 2.0 * z * wn * w);
    for k in (80_000..100_000).step_by(997) {
        // ZOH adds a delay of h/2 to the held input
        let want = g.norm() * (w * (t[k] - h / 2.0) + g.arg()).sin();
        assert!((y[k] - want).abs() < 1e-6, "t={}: {} vs {want}", t[k], y[k]);
    }
}

/// RK4 of ẋ = A x + B u with constant u over `h` in `steps` sub-steps.
fn rk4(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    x0: &DMatrix<f64>,
    u: f64,
    h: f64,
    steps: usize,
) -> DMatrix<f64> {
    let dt = h / steps as f64;
    let f = |x: &DMatrix<f64>| a * x + b * u;
    let mut x = x0.clone();
    for _ in 0..steps {
        let k1 = f(&x);
        let k2 = f(&(&x + &k1 * (dt / 2.0)));
        let k3 = f(&(&x + &k2 * (dt / 2.0)));
        let k4 = f(&(&x + &k3 * dt));
        x += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (dt / 6.0);
    }
    x
}

#[test]
fn default_rig_discretisation_matches_fine_rk4() {
    let sys = Plant::new(&Rig::default()).closed_loop_outputs(true);
    let n = sys.order();
    let h = 0.01;
    let z = Zoh::new(&sys.a, &sys.b, h).unwrap();
    // typical magnitudes of the states (m, m/s, Pa, Pa, rad/s ×2, N·m ×2, rad/s ×2) so the
    // comparison weighs every state alike
    let typical = [1e-3, 1e-2, 1e5, 1e5, 10.0, 10.0, 0.1, 0.1, 10.0, 10.0];
    let s = DMatrix::from_diagonal(&nalgebra::DVector::from_column_slice(&typical[..n]));
    let s_inv = s.clone().try_inverse().unwrap();
    for j in 0..n {
        let mut e = DMatrix::zeros(n, 1);
        e[(j, 0)] = 1.0;
        let col = rk4(&sys.a, &sys.b, &e, 0.0, h, 20_000);
        let diff = &s_inv * (col - z.phi.column(j)) * typical[j];
        let scale = (&s_inv * &z.phi * &s).abs().max();
        assert!(
            diff.abs().max() < 1e-9 * scale,
            "Φ column {j}: {}",
            diff.abs().max()
        );
    }
    let g = rk4(&sys.a, &sys.b, &DMatrix::zeros(n, 1), 1.0, h, 20_000);
    let diff = &s_inv * (g - &z.gamma) * 1e-3;
    let scale = (&s_inv * &z.gamma * 1e-3).abs().max();
    assert!(diff.abs().max() < 1e-9 * scale, "Γ: {}", diff.abs().max());
}

#[test]
fn non_uniform_record_equals_the_fine_uniform_hold() {
    // sample times on a 5 ms lattice with irregular gaps; the same held input on the uniform
    // 5 ms grid must give the same states at the common times
    let sys = Plant::new(&Rig::default()).closed_loop_outputs(true);
    let ticks = [
        0usize, 2, 3, 7, 8, 20, 21, 22, 40, 41, 60, 100, 101, 160, 200,
    ];
    let t: Vec<f64> = ticks.iter().map(|&k| k as f64 * 0.005).collect();
    let u: Vec<f64> = ticks
        .iter()
        .map(|&k| 1e-3 * ((k as f64) * 0.37).sin())
        .collect();
    let x0 = vec![0.0; sys.order()];
    let coarse = Simulator::new(&sys).run(&t, &u, &x0).unwrap();
    let fine_t: Vec<f64> = (0..=200).map(|k| k as f64 * 0.005).collect();
    let fine_u: Vec<f64> = (0..=200)
        .map(|k| {
            let i = ticks.iter().rposition(|&tk| tk <= k).unwrap();
            u[i]
        })
        .collect();
    let fine = Simulator::new(&sys).run(&fine_t, &fine_u, &x0).unwrap();
    let xc = coarse.output(0);
    let xf = fine.output(0);
    let peak = xf.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (i, &k) in ticks.iter().enumerate() {
        assert!(
            (xc[i] - xf[k]).abs() < 1e-10 * peak,
            "tick {k}: {} vs {}",
            xc[i],
            xf[k]
        );
    }
}
