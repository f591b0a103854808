//! MATLAB/Octave files: the model as an `ss` object with named states, inputs and outputs, a
//! grey-box model function for System Identification Toolbox's `idgrey`, and MAT-files of the
//! model, of signals and of Bode data (docs/matlab.md). Numbers in function files are written
//! in Rust's shortest round-trip form, so MATLAB and Octave read back exactly the f64 values
//! pumpcyl computed with.

use crate::matfile::{var_name, MatWriter};
use crate::plot::BodeSeries;
use nalgebra::DMatrix;
use pumpcyl::ident::Standstill;
use pumpcyl::loops::{grey_loop, GreyLoop, ModelView, Port};
use pumpcyl::lti::{StateInfo, StateSpace};
use pumpcyl::model::Plant;
use pumpcyl::response::Signals;
use pumpcyl::rig::Rig;
use pumpcyl::units::{PA_PER_BAR, RAD_S_PER_RPM};
use std::fmt::Write as _;

/// A model with everything a reader needs: matrices, names, units and what it is.
#[derive(Debug, Clone)]
pub struct Described<'a> {
    /// The matrices (SI).
    pub sys: &'a StateSpace,
    /// State names and units.
    pub states: &'a [StateInfo],
    /// Inputs, in order.
    pub inputs: Vec<Port>,
    /// Outputs, in order.
    pub outputs: Vec<Port>,
    /// What the model is (one line).
    pub title: String,
    /// The operating point the deviations are taken from: (name, value, unit).
    pub operating_point: Vec<(String, f64, String)>,
}

/// Whether `name` can name a MATLAB function (and so its file): see [`crate::matfile::is_var_name`].
pub fn is_function_name(name: &str) -> bool {
    crate::matfile::is_var_name(name)
}

/// A number MATLAB reads back as exactly this f64.
fn num(v: f64) -> String {
    format!("{v:?}")
}

/// A matrix literal, one row a line.
fn matrix_literal(m: &DMatrix<f64>) -> String {
    if m.nrows() == 0 || m.ncols() == 0 {
        return format!("zeros({}, {})", m.nrows(), m.ncols());
    }
    let rows: Vec<String> = m
        .row_iter()
        .map(|r| r.iter().map(|&v| num(v)).collect::<Vec<_>>().join(", "))
        .collect();
    format!("[\n    {}\n]", rows.join(";\n    "))
}

/// A cell array of strings `{'a', 'b'}`.
fn cell(names: impl Iterator<Item = String>) -> String {
    let items: Vec<String> = names
        .map(|n| format!("'{}'", n.replace('\'', "''")))
        .collect();
    format!("{{{}}}", items.join(", "))
}

/// `function [sys, op] = NAME()`: the model as a continuous `ss` with state, input and output
/// names (units in comments, and as `StateUnit`/`InputUnit`/`OutputUnit` in MATLAB, which has
/// them), and `op`, a struct of the operating point.
pub fn ss_function(name: &str, m: &Described) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "function [sys, op] = {name}()");
    let _ = writeln!(s, "%{}  {}", name.to_uppercase(), m.title);
    let _ = writeln!(
        s,
        "%   sys = {name}() is the continuous-time state-space model (SI units), linear in\n\
         %   deviations from the operating point; [sys, op] = {name}() also gives the operating\n\
         %   point as a struct. Written by pumpcyl (docs/matlab.md). Needs `pkg load control` in Octave."
    );
    let _ = writeln!(s, "%\n%   States:");
    for (i, st) in m.states.iter().enumerate() {
        let _ = writeln!(s, "%     {:>2}  {:<6} ({})", i + 1, st.name, st.unit);
    }
    for (what, ports) in [("Inputs", &m.inputs), ("Outputs", &m.outputs)] {
        let _ = writeln!(s, "%   {what}:");
        for (i, p) in ports.iter().enumerate() {
            let _ = writeln!(
                s,
                "%     {:>2}  {:<6} ({}) {}",
                i + 1,
                p.name,
                p.unit,
                p.meaning
            );
        }
    }
    for (label, mat) in [
        ("A", &m.sys.a),
        ("B", &m.sys.b),
        ("C", &m.sys.c),
        ("D", &m.sys.d),
    ] {
        let _ = writeln!(s, "{label} = {};", matrix_literal(mat));
    }
    let names = |f: &dyn Fn() -> Vec<String>| cell(f().into_iter());
    let state_names = names(&|| m.states.iter().map(|x| x.name.clone()).collect());
    let in_names = names(&|| m.inputs.iter().map(|x| x.name.clone()).collect());
    let out_names = names(&|| m.outputs.iter().map(|x| x.name.clone()).collect());
    let _ = writeln!(
        s,
        "sys = ss(A, B, C, D, 'statename', {state_names}, 'inputname', {in_names}, ...\n    \
         'outputname', {out_names});"
    );
    let units = |f: &dyn Fn() -> Vec<String>| cell(f().into_iter());
    let _ = writeln!(
        s,
        "if ~exist('OCTAVE_VERSION', 'builtin')  % units are properties in MATLAB only\n    \
         sys.StateUnit = {};\n    sys.InputUnit = {};\n    sys.OutputUnit = {};\nend",
        units(&|| m.states.iter().map(|x| x.unit.clone()).collect()),
        units(&|| m.inputs.iter().map(|x| x.unit.clone()).collect()),
        units(&|| m.outputs.iter().map(|x| x.unit.clone()).collect()),
    );
    let _ = writeln!(s, "op = struct();");
    for (field, v, unit) in &m.operating_point {
        let _ = writeln!(s, "op.{field} = {};  % {unit}", num(*v));
    }
    s.push_str("end\n");
    s
}

pub use pumpcyl::circuit::dpm::ParamEntry;

/// `function [A, B, C, D] = NAME(beta_bar, b, c12, Ts, varargin)`: the rig's loop with β, b and
/// c12 free, c1 and c2 from the standstill continuity equations at each c12 (as
/// [`Standstill::leakage`]), in the form `idgrey` calls (parameters, then the sample time, then
/// optional arguments, ignored here). Ts = 0 gives the continuous model; Ts > 0 its zero-order
/// hold discretisation (the exponential of [[A, B]; [0, 0]]·Ts).
pub fn greybox_function(
    name: &str,
    rig: &Rig,
    which: GreyLoop,
    standstill: Standstill,
    title: &str,
    outputs: &[Port],
    inputs: &[Port],
) -> String {
    let sys = grey_loop(rig, which);
    let plant = Plant::new(rig);
    let si = plant.si;
    let states = plant.states();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "function [A, B, C, D] = {name}(beta_bar, b, c12, Ts, varargin)"
    );
    let _ = writeln!(s, "%{}  grey-box model: {title}", name.to_uppercase());
    let _ = writeln!(
        s,
        "%   [A, B, C, D] = {name}(beta_bar, b, c12, Ts) for System Identification Toolbox's\n\
         %   idgrey (written by pumpcyl, docs/matlab.md). Free parameters:\n\
         %     beta_bar  effective bulk modulus (bar)\n\
         %     b         viscous friction (N s/m)\n\
         %     c12       cross-port leakage (m^5/(N s))\n\
         %   Ts = 0: continuous time; Ts > 0: zero-order-hold discretisation. Extra arguments\n\
         %   are accepted and ignored. The chamber leakages c1, c2 follow from the standstill\n\
         %   continuity equations at each c12. Example:\n\
         %     sys = idgrey('{name}', {{'beta_bar', {}; 'b', {}; 'c12', {}}}, 'c');\n\
         %     sys = greyest(iddata(y, u, 0.01), sys);\n\
         %   States (SI): {}",
        num(rig.beta_bar),
        num(rig.viscous_friction_ns_per_m),
        num(rig.c12_m5_per_ns),
        states
            .iter()
            .map(|x| format!("{} ({})", x.name, x.unit))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let list = |ports: &[Port]| {
        ports
            .iter()
            .map(|p| format!("{} ({})", p.name, p.unit))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let _ = writeln!(
        s,
        "%   Inputs: {}\n%   Outputs: {}",
        list(inputs),
        list(outputs)
    );
    let consts: [(&str, f64, &str); 7] = [
        ("A1", si.a1, "piston area (m^2)"),
        ("A2", si.a2, "annulus area (m^2)"),
        ("V1", si.v1, "chamber 1 volume at x0 (m^3)"),
        ("V2", si.v2, "chamber 2 volume at x0 (m^3)"),
        ("D1", si.d[0], "pump 1 displacement (m^3/rad)"),
        ("D2", si.d[1], "pump 2 displacement (m^3/rad)"),
        ("m", si.mass, "moving mass (kg)"),
    ];
    for (k, v, what) in consts {
        let _ = writeln!(s, "{k} = {};  % {what}", num(v));
    }
    let _ = writeln!(s, "F_ext = {};  % external force (N)", num(si.f_ext));
    let _ = writeln!(
        s,
        "% standstill under feedback: pump speeds feeding the leakage, chamber 1 pressure\n\
         w1_s = {};  % rad/s ({} rpm)\nw2_s = {};  % rad/s ({} rpm)\np1_s = {};  % Pa ({} bar)",
        num(standstill.w1_rpm * RAD_S_PER_RPM),
        standstill.w1_rpm,
        num(standstill.w2_rpm * RAD_S_PER_RPM),
        standstill.w2_rpm,
        num(standstill.p1_bar * PA_PER_BAR),
        standstill.p1_bar
    );
    s.push_str(
        "p2_s = (p1_s*A1 - F_ext)/A2;  % force balance at rest, p1 A1 - p2 A2 = F_ext\n\
         cross = c12*(p1_s - p2_s);\n\
         c1 = (D1*w1_s + D2*w2_s - cross)/p1_s;  % continuity in chamber 1 at rest\n\
         c2 = (-D1*w1_s + cross)/p2_s;  % continuity in chamber 2 at rest\n\
         beta = beta_bar*1e5;  % Pa\n\
         k1 = beta/V1;\n\
         k2 = beta/V2;\n",
    );
    for (label, mat) in [("A", &sys.a), ("B", &sys.b), ("C", &sys.c), ("D", &sys.d)] {
        let _ = writeln!(s, "{label} = {};", matrix_literal(mat));
    }
    s.push_str("% the entries that depend on the parameters\n");
    let fixed = [si.c1, si.c2, si.c12];
    let dpm = (plant.dpm()).expect("the standstill (loops::standstill_of) refuses other circuits");
    for e in dpm.param_entries(si.beta, si.b, fixed) {
        let _ = writeln!(s, "A({}, {}) = {};", e.row + 1, e.col + 1, e.expr);
    }
    s.push_str(
        "if Ts > 0\n    n = size(A, 1);\n    k = size(B, 2);\n    \
         M = expm([A, B; zeros(k, n + k)]*Ts);\n    A = M(1:n, 1:n);\n    \
         B = M(1:n, n+1:end);\nend\nend\n",
    );
    s
}

/// MAT variables named as the signal CSV columns (`time_s`, `x_ref_mm`, `x_mm`, `e_mm`,
/// `p1_bar`, `p2_bar`, `w1_rpm`, `w2_rpm`; units as the names say): the first block (the
/// measured record if there is one) with plain names, block k ≥ 2 with the suffix `_k`, empty
/// signals left out; `series_labels` names the blocks (`1: measured; 2: nominal`).
fn signal_columns(w: &mut MatWriter, series: &[(String, &Signals)], measured: Option<&Signals>) {
    let mut blocks: Vec<(&str, &Signals)> = Vec::new();
    if let Some(m) = measured {
        blocks.push(("measured", m));
    }
    blocks.extend(series.iter().map(|(l, s)| (l.as_str(), *s)));
    let mut labels = Vec::new();
    for (k, (label, s)) in blocks.iter().enumerate() {
        labels.push(format!("{}: {label}", k + 1));
        for (name, v) in s.named() {
            if !v.is_empty() {
                w.column(&format!("{name}{}", block_suffix(k)), v);
            }
        }
    }
    w.text("series_labels", &labels.join("; "));
}

/// The suffix of the variables of block `k` (0-based) of a MAT-file: none for the first,
/// `_2`, `_3`, … after it.
fn block_suffix(k: usize) -> String {
    if k == 0 {
        String::new()
    } else {
        format!("_{}", k + 1)
    }
}

/// A MAT-file (docs/matlab.md#mat-files-of-results) of signals and named columns of scalars.
/// The signals are named as the signal CSV columns (`time_s`, `x_ref_mm`, `x_mm`, `e_mm`,
/// `p1_bar`, `p2_bar`, `w1_rpm`, `w2_rpm`): the first block (`measured` if given) plain, block
/// k ≥ 2 suffixed `_k`, with `series_labels` naming the blocks. The scalars hold one value per
/// series, `None` written as NaN (not reached, not settled); `description` heads the file.
pub fn signals_mat(
    description: &str,
    series: &[(String, &Signals)],
    measured: Option<&Signals>,
    scalars: &[(&str, Vec<Option<f64>>)],
) -> Vec<u8> {
    let mut w = MatWriter::new(description);
    signal_columns(&mut w, series, measured);
    for (name, values) in scalars {
        let v: Vec<f64> = values.iter().map(|x| x.unwrap_or(f64::NAN)).collect();
        w.column(&var_name(name), &v);
    }
    w.into_bytes()
}

/// The Bode MAT-file (docs/matlab.md#mat-files-of-results): `freq_hz` (Hz), `mag_db` (dB) and
/// `phase_deg` (deg) per series (suffixed `_k` for series k ≥ 2), `series_labels`. Every
/// series is on the first one's frequencies.
pub fn bode_mat(series: &[BodeSeries]) -> Vec<u8> {
    let mut w = MatWriter::new("Bode diagram of the position open loop");
    w.column("freq_hz", &series[0].freq_hz);
    let mut labels = Vec::new();
    for (k, s) in series.iter().enumerate() {
        let suffix = block_suffix(k);
        labels.push(format!("{}: {}", k + 1, s.label));
        w.column(&format!("mag_db{suffix}"), &s.mag_db)
            .column(&format!("phase_deg{suffix}"), &s.phase_deg);
    }
    w.text("series_labels", &labels.join("; "));
    w.into_bytes()
}

/// The model as a MAT-file (docs/matlab.md#the-model-as-an-ss-object): `A`, `B`, `C`, `D`
/// (SI), the names `state_names`, `state_units`, `input_names`, `output_names` (comma
/// separated), `description`, and `op_<name>` for each value of the operating point.
pub fn model_mat(view: &ModelView) -> Vec<u8> {
    let mut w = MatWriter::new(&view.title);
    for (name, m) in [
        ("A", &view.sys.a),
        ("B", &view.sys.b),
        ("C", &view.sys.c),
        ("D", &view.sys.d),
    ] {
        w.matrix(name, m.nrows(), m.ncols(), m.as_slice());
    }
    let join = |v: Vec<&str>| v.join(",");
    w.text(
        "state_names",
        &join(view.states.iter().map(|s| s.name.as_str()).collect()),
    )
    .text(
        "state_units",
        &join(view.states.iter().map(|s| s.unit.as_str()).collect()),
    )
    .text(
        "input_names",
        &join(view.inputs.iter().map(|s| s.name.as_str()).collect()),
    )
    .text(
        "output_names",
        &join(view.outputs.iter().map(|s| s.name.as_str()).collect()),
    )
    .text("description", &view.title);
    for (name, v, _) in &view.operating_point {
        w.scalar(&format!("op_{name}"), *v);
    }
    w.into_bytes()
}

/// The model of `view` with its names, as [`ss_function`] writes it.
pub fn described(view: &ModelView) -> Described<'_> {
    Described {
        sys: &view.sys,
        states: &view.states,
        inputs: view.inputs.clone(),
        outputs: view.outputs.clone(),
        title: view.title.clone(),
        operating_point: view.operating_point.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use pumpcyl::circuit::Role;
    use pumpcyl::rig::MotorModel;

    /// The parameter entries hold the values the model assembles, for every variant, and the
    /// rest of the hydraulic rows is zero (so the grey-box function misses nothing).
    #[test]
    fn param_entries_are_the_models_own() {
        let variants = [
            Rig::default(),
            Rig {
                motor_model: MotorModel::FirstOrder,
                ..Rig::default()
            },
            Rig {
                feedforward: false,
                beta_bar: 37.8,
                c12_m5_per_ns: 3e-10,
                ..Rig::default()
            },
        ];
        for rig in variants {
            let plant = Plant::new(&rig);
            let si = plant.si;
            let entries =
                (plant.dpm().unwrap()).param_entries(si.beta, si.b, [si.c1, si.c2, si.c12]);
            for which in [
                GreyLoop::Open {
                    sum_pressure: false,
                },
                GreyLoop::Open { sum_pressure: true },
                GreyLoop::Closed { sum_pressure: true },
            ] {
                let sys = grey_loop(&rig, which);
                let mut covered = DMatrix::zeros(sys.a.nrows(), sys.a.ncols());
                for e in &entries {
                    assert_eq!(sys.a[(e.row, e.col)], e.value, "{e:?}");
                    covered[(e.row, e.col)] = e.value;
                }
                for row in plant.states_of(Role::Pressure) {
                    assert_eq!(sys.a.row(row), covered.row(row));
                }
            }
        }
    }

    #[test]
    fn numbers_round_trip_and_names_are_checked() {
        for v in [0.1, 1.2e-10, -16500000.0, 1.0 / 3.0, 5e-324] {
            assert_eq!(num(v).parse::<f64>().unwrap(), v);
        }
        assert!(is_function_name("open_loop") && !is_function_name("open-loop"));
    }

    #[test]
    fn a_signals_mat_has_a_block_per_series_and_nan_for_none() {
        let signals = Signals {
            time_s: vec![0.0, 0.1, 0.2],
            x_ref_mm: vec![5.0; 3],
            x_mm: vec![0.0, 2.0, 4.5],
            e_mm: vec![5.0, 3.0, 0.5],
            ..Signals::default()
        };
        let series = [("nominal".to_string(), &signals)];
        let bytes = signals_mat(
            "test",
            &series,
            Some(&signals),
            &[("rise_time_s", vec![None])],
        );
        let vars = pumpcyl::matfile::read(&bytes).unwrap();
        let get = |name: &str| vars.iter().find(|v| v.name == name);
        // the measured block plain, the series suffixed _2; the empty pressures left out
        assert_eq!(get("x_mm").unwrap().vector().unwrap(), &[0.0, 2.0, 4.5]);
        assert_eq!(get("e_mm_2").unwrap().vector().unwrap(), &[5.0, 3.0, 0.5]);
        assert!(get("p1_bar").is_none() && get("x_mm_3").is_none());
        assert!(get("series_labels").is_some());
        assert!(get("rise_time_s").unwrap().vector().unwrap()[0].is_nan());
    }

    #[test]
    fn a_bode_mat_suffixes_every_series_after_the_first() {
        let series = |label: &str, mag: f64| BodeSeries {
            label: label.into(),
            freq_hz: vec![0.1, 1.0],
            mag_db: vec![mag, mag - 20.0],
            phase_deg: vec![-90.0, -120.0],
        };
        let bytes = bode_mat(&[series("nominal", 10.0), series("beta_bar=37.8", 4.0)]);
        let names: Vec<String> = pumpcyl::matfile::read(&bytes)
            .unwrap()
            .into_iter()
            .map(|v| v.name)
            .collect();
        let want = ["freq_hz", "mag_db", "phase_deg", "mag_db_2", "phase_deg_2"];
        assert_eq!(names[..5], want);
        assert_eq!(names[5], "series_labels");
    }
}
