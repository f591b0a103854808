//! `pumpcyl._pumpcyl`: the Python binding of the pumpcyl library, a thin layer that converts
//! Python values and numpy arrays to the library's types, calls the library and converts back.
//! No analysis happens here. Every library error becomes `pumpcyl.PumpcylError` (a
//! `ValueError`) with the one-line message the command line prints.
//!
//! Units follow the library: the unit is part of every name (`beta_bar`, `f_hz`, `x_mm`).

use numpy::ndarray::Array2;
use numpy::{AllowTypeChange, IntoPyArray, PyArray1, PyArray2, PyArrayLike1};
use pyo3::create_exception;
use pyo3::exceptions::{PyAttributeError, PyUserWarning, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use std::ffi::CString;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::RecvTimeoutError;
use std::time::Duration;

use nalgebra::DMatrix;
use pumpcyl::ident::{self, Experiment, Grid, Standstill};
use pumpcyl::loops::Loop;
use pumpcyl::lti::{self, StateSpace};
use pumpcyl::model::Plant;
use pumpcyl::record::Record;
use pumpcyl::response::{self, Baseline, Signals};
use pumpcyl::rig::{Rig, RigError};
use pumpcyl::select::SelectError;
use pumpcyl_present::request::identify::{Datasets, Identify, Search, Source};
use pumpcyl_present::request::{self, Document, FieldError, Hooks, Request, RigInput};

create_exception!(
    pumpcyl,
    PumpcylError,
    PyValueError,
    "An error of pumpcyl: bad input or a numerical failure, with the command line's message."
);

/// Any library error as `PumpcylError` with its message on one line.
fn err(e: impl std::fmt::Display) -> PyErr {
    let text = e.to_string();
    let lines: Vec<&str> = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect();
    PumpcylError::new_err(lines.join(" "))
}

/// A value serialised by the library, as plain Python data (dicts, lists, floats, None); the
/// JSON text is written with the GIL released (a run's signals make it long).
fn to_py(py: Python<'_>, value: &(impl serde::Serialize + Sync)) -> PyResult<Py<PyAny>> {
    let text = py.detach(|| serde_json::to_string(value)).map_err(err)?;
    Ok(py.import("json")?.call_method1("loads", (text,))?.unbind())
}

/// A Python value's `repr`, cut to a readable length.
fn short_repr(value: &Bound<'_, PyAny>) -> String {
    const MAX_CHARS: usize = 60;
    let text = value.repr().map_or_else(|_| "?".into(), |r| r.to_string());
    match text.char_indices().nth(MAX_CHARS) {
        Some((cut, _)) => format!("{}…", &text[..cut]),
        None => text,
    }
}

/// A Python argument of a function, or an item of one (`standstill['w1_rpm']`), as messages
/// name it: `call(name=value): problem`.
#[derive(Debug, Clone)]
struct Arg<'a> {
    /// The function or class called (`Rig`, `identify`).
    call: &'a str,
    /// The argument's name, with the item's keys.
    name: String,
}

impl<'a> Arg<'a> {
    fn new(call: &'a str, name: &str) -> Self {
        Arg {
            call,
            name: name.to_string(),
        }
    }

    /// The item `key` (a dict key or a list index) of this argument.
    fn item(&self, key: &Bound<'_, PyAny>) -> Self {
        Arg {
            call: self.call,
            name: format!("{}[{}]", self.name, short_repr(key)),
        }
    }

    /// `name=value`: the argument and the value given.
    fn given(&self, value: &Bound<'_, PyAny>) -> String {
        format!("{}={}", self.name, short_repr(value))
    }

    /// The error `problem` of the value given: `call(name=value): problem`, on one line.
    fn error(&self, value: &Bound<'_, PyAny>, problem: impl std::fmt::Display) -> PyErr {
        err(format!("{}({}): {problem}", self.call, self.given(value)))
    }

    /// The float value of this argument, refused with `rule` unless `ok`.
    fn check(&self, py: Python<'_>, value: f64, ok: bool, rule: &str) -> PyResult<f64> {
        if ok {
            return Ok(value);
        }
        Err(self.error(PyFloat::new(py, value).as_any(), rule))
    }
}

/// A Python value as TOML, types kept (bool, int, float, str, list or tuple, dict with str
/// keys; numpy values through `tolist()`); anything else is an error naming the argument.
fn toml_of(arg: &Arg<'_>, v: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
    use toml::Value as T;
    if let Ok(b) = v.cast::<PyBool>() {
        return Ok(T::Boolean(b.is_true()));
    }
    if v.is_instance_of::<PyInt>() {
        let big = |_| arg.error(v, "an integer beyond 64 bits");
        return v.extract::<i64>().map(T::Integer).map_err(big);
    }
    if let Ok(x) = v.cast::<PyFloat>() {
        return Ok(T::Float(x.value()));
    }
    if let Ok(s) = v.cast::<PyString>() {
        return Ok(T::String(s.to_cow()?.into_owned()));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut table = toml::Table::new();
        for (k, x) in d {
            let key: String = k.extract().map_err(|_| arg.error(v, "keys must be str"))?;
            table.insert(key, toml_of(&arg.item(&k), &x)?);
        }
        return Ok(T::Table(table));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let py = v.py();
        let items = v
            .try_iter()?
            .enumerate()
            .map(|(i, x)| toml_of(&arg.item(i.into_pyobject(py)?.as_any()), &x?))
            .collect::<PyResult<_>>()?;
        return Ok(T::Array(items));
    }
    if v.hasattr("tolist")? {
        return toml_of(arg, &v.call_method0("tolist")?);
    }
    let kind = v.get_type().name()?;
    let problem = format!("takes a number, bool, str, list or dict, not a {kind}");
    Err(arg.error(v, problem))
}

/// A dict argument (`standstill`, `grid`) as a library type; an error names the key.
fn from_py<T: serde::de::DeserializeOwned>(arg: &Arg<'_>, value: &Bound<'_, PyAny>) -> PyResult<T> {
    toml_of(arg, value)?
        .try_into()
        .map_err(|e: toml::de::Error| {
            let problem = pumpcyl::source_files::serde_message(e.message());
            // the message ends with the key path, "in `key.sub`", when it concerns a key
            let shown = e.to_string();
            let key = shown
                .lines()
                .filter_map(|l| l.trim().strip_prefix("in `")?.strip_suffix('`'))
                .next_back()
                .and_then(|path| path.split('.').next())
                .map(|k| PyString::new(value.py(), k).into_any());
            match key.and_then(|k| Some((value.get_item(&k).ok()?, k))) {
                Some((item, k)) => arg.item(&k).error(&item, problem),
                None => arg.error(value, problem),
            }
        })
}

/// Keyword arguments of `call` in the core's override form, `KEY=VALUE` with the value in
/// TOML, each with its argument and value for messages.
fn assignments<'a, 'py>(
    call: &'a str,
    overrides: Option<&Bound<'py, PyDict>>,
) -> PyResult<Vec<(Arg<'a>, Bound<'py, PyAny>, String)>> {
    let Some(kw) = overrides else {
        return Ok(Vec::new());
    };
    kw.iter()
        .map(|(k, v)| {
            let arg = Arg::new(call, &k.extract::<String>()?);
            let assignment = format!("{}={}", arg.name, toml_of(&arg, &v)?);
            Ok((arg, v, assignment))
        })
        .collect()
}

/// The call with the keyword arguments a complaint about `key` concerns, `call(key=value)`:
/// its own, or all of them when a rule ties keys together.
fn concerned(call: &str, given: &[(Arg<'_>, Bound<'_, PyAny>, String)], key: &str) -> String {
    let named = |(arg, v, _): &(Arg<'_>, Bound<'_, PyAny>, String)| arg.given(v);
    let own = given.iter().filter(|(arg, ..)| arg.name == key);
    let mut shown: Vec<String> = own.map(named).collect();
    if shown.is_empty() {
        shown = given.iter().map(named).collect();
    }
    format!("{call}({})", shown.join(", "))
}

/// The error of an override `KEY=VALUE` that does not fit (all of them, space-separated, when
/// none alone is at fault), in the call's words: `call(key=value): message`.
fn misfit(
    call: &str,
    given: &[(Arg<'_>, Bound<'_, PyAny>, String)],
    assignment: &str,
    message: &str,
) -> PyErr {
    let key = assignment.split('=').next().unwrap_or_default().trim();
    err(format!("{}: {message}", concerned(call, given, key)))
}

/// A 1-D array argument (a numpy array or any sequence of numbers) as float64 values.
fn floats(arg: &Arg<'_>, value: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    value
        .extract::<PyArrayLike1<'_, f64, AllowTypeChange>>()
        .map(|a| a.as_array().to_vec())
        .map_err(|_| arg.error(value, "must be a 1-D array or sequence of numbers"))
}

fn array1<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, PyArray1<f64>> {
    v.to_vec().into_pyarray(py)
}

fn array2<'py>(py: Python<'py>, m: &DMatrix<f64>) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)]).into_pyarray(py)
}

// ---------------------------------------------------------------------------------------------
// Rig

/// A rig description: the article's rig with overrides, or a TOML file. Immutable; `replace`
/// returns a new rig. Every TOML key is an attribute, with its unit in its name.
#[pyclass(module = "pumpcyl._pumpcyl", name = "Rig", frozen, eq)]
#[derive(Clone)]
struct PyRig {
    rig: Rig,
    /// The keys its rig file left out, but those set since (`replace`); `None` for a rig made
    /// from the article's (docs/formats.md#rig-toml).
    defaulted: Option<Vec<&'static str>>,
}

impl PartialEq for PyRig {
    /// Two rigs are equal when their keys are, wherever they came from.
    fn eq(&self, other: &PyRig) -> bool {
        self.rig == other.rig
    }
}

fn toml_to_py(py: Python<'_>, v: &toml::Value) -> PyResult<Py<PyAny>> {
    Ok(match v {
        toml::Value::Float(x) => x.into_pyobject(py)?.into_any().unbind(),
        toml::Value::Integer(i) => i.into_pyobject(py)?.into_any().unbind(),
        toml::Value::Boolean(b) => b.into_pyobject(py)?.to_owned().into_any().unbind(),
        toml::Value::String(s) => s.into_pyobject(py)?.into_any().unbind(),
        toml::Value::Array(items) => {
            let list = PyList::empty(py);
            for item in items {
                list.append(toml_to_py(py, item)?)?;
            }
            list.into_any().unbind()
        }
        toml::Value::Table(table) => {
            let d = PyDict::new(py);
            for (k, v) in table {
                d.set_item(k, toml_to_py(py, v)?)?;
            }
            d.into_any().unbind()
        }
        other => other.to_string().into_pyobject(py)?.into_any().unbind(),
    })
}

impl PyRig {
    fn table(&self) -> toml::Table {
        self.rig.table()
    }

    /// This rig with the keyword overrides of `call` (`Rig`, `Rig.replace`). A value out of
    /// range names the argument and the value given (`Rig(beta_bar=nan): key `beta_bar` = NaN:
    /// must be a finite number`), or all of them when the rule ties keys together; a type or
    /// key error likewise (`Rig(mass_kg='4898'): key `mass_kg` takes a float`).
    fn with(&self, call: &str, overrides: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let given = assignments(call, overrides)?;
        let all: Vec<String> = given.iter().map(|(.., a)| a.clone()).collect();
        let rig = self.rig.with_overrides(&all).map_err(|mut e| {
            match &mut e {
                RigError::Invalid {
                    source_name, key, ..
                } => *source_name = concerned(call, &given, key),
                RigError::Set {
                    assignment,
                    message,
                    ..
                } => return misfit(call, &given, assignment, message),
                _ => {}
            }
            err(e)
        })?;
        let set: Vec<&str> = (all.iter())
            .filter_map(|a| a.split_once('=').map(|(k, _)| k.trim()))
            .collect();
        let defaulted = (self.defaulted.as_ref())
            .map(|keys| keys.iter().copied().filter(|k| !set.contains(k)).collect());
        Ok(PyRig { rig, defaulted })
    }

    /// This rig's result document `doc` with the keys its file left out
    /// (`pumpcyl_present::documents::with_rig_defaulted_keys`, as the command line's).
    fn document(&self, doc: serde_json::Value) -> serde_json::Value {
        pumpcyl_present::documents::with_rig_defaulted_keys(doc, self.defaulted.as_deref())
    }

    /// The rig as a request runs on it, named by its `repr`.
    fn input(&self) -> RigInput {
        RigInput {
            rig: self.rig.clone(),
            name: self.__repr__(),
            defaulted: self.defaulted.clone(),
        }
    }

    /// The rig of `file` (read from `name`), a `UserWarning` naming the keys it leaves out and
    /// the values they take.
    fn noting_defaults(py: Python<'_>, file: pumpcyl::rig::RigFile, name: &str) -> PyResult<Self> {
        if let Some(note) = file.note(name, &[]) {
            let category = py.get_type::<PyUserWarning>();
            PyErr::warn(py, category.as_any(), &CString::new(note)?, 1)?;
        }
        Ok(PyRig {
            rig: file.rig,
            defaulted: Some(file.defaulted),
        })
    }
}

/// The class docstring of `Rig`: its own words, then every key with its unit and meaning.
fn rig_doc(own: &str) -> String {
    let keys: Vec<String> = Rig::key_docs()
        .map(|(key, doc)| format!("    {key}: {doc}"))
        .collect();
    format!(
        "{own}\n\nKeys (read-only attributes and keyword arguments; unit, meaning):\n{}",
        keys.join("\n")
    )
}

#[pymethods]
impl PyRig {
    /// The article's rig with keyword overrides, same keys as the TOML: `Rig(beta_bar=37.8)`.
    #[new]
    #[pyo3(signature = (**overrides))]
    fn new(overrides: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        PyRig {
            rig: Rig::default(),
            defaulted: None,
        }
        .with("Rig", overrides)
    }

    /// Read a rig TOML file. Absent keys take the article's values, except `mass_by_position`,
    /// `[]` (one mass over the stroke); a `UserWarning` names them (docs/formats.md#rig-toml).
    #[staticmethod]
    fn from_toml(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let file =
            Rig::from_file_with_defaults_in(&pumpcyl::source_files::Disk, &path).map_err(err)?;
        PyRig::noting_defaults(py, file, &path.display().to_string())
    }

    /// Parse rig TOML text; `name` stands for the file in messages. Absent keys as in
    /// `from_toml`, named in a `UserWarning`.
    #[staticmethod]
    #[pyo3(signature = (text, name = "<string>"))]
    fn from_toml_str(py: Python<'_>, text: &str, name: &str) -> PyResult<Self> {
        let file = Rig::from_toml_str_with_defaults(text, name).map_err(err)?;
        PyRig::noting_defaults(py, file, name)
    }

    /// A new rig with keyword overrides applied; this one is unchanged.
    #[pyo3(signature = (**overrides))]
    fn replace(&self, overrides: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        self.with("Rig.replace", overrides)
    }

    /// Every key and value, units in the key names.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (k, v) in &self.table() {
            d.set_item(k, toml_to_py(py, v)?)?;
        }
        Ok(d)
    }

    /// The rig as commented TOML (what `pumpcyl rig` prints), readable by `from_toml`.
    fn to_toml(&self) -> String {
        self.rig.to_commented_toml()
    }

    fn __getattr__(&self, py: Python<'_>, name: &str) -> PyResult<Py<PyAny>> {
        match self.table().get(name) {
            Some(v) => toml_to_py(py, v),
            None if pumpcyl::rig::is_optional_key(name) => Ok(py.None()),
            None => Err(PyAttributeError::new_err(format!(
                "Rig has no key `{name}`"
            ))),
        }
    }

    /// The methods and every rig key.
    fn __dir__(slf: &Bound<'_, Self>) -> PyResult<Vec<String>> {
        let mut names: Vec<String> = slf.get_type().dir()?.extract()?;
        names.extend(Rig::key_docs().map(|(key, _)| key.to_string()));
        names.sort();
        names.dedup();
        Ok(names)
    }

    fn __repr__(&self) -> String {
        let default = PyRig {
            rig: Rig::default(),
            defaulted: None,
        }
        .table();
        let changed: Vec<String> = self
            .table()
            .iter()
            .filter(|(k, v)| default.get(*k) != Some(v))
            .map(|(k, v)| format!("{k}={v}"))
            .collect();
        format!("Rig({})", changed.join(", "))
    }
}

// ---------------------------------------------------------------------------------------------
// Frequency domain

/// The analysed loop: the open loop of the article (the article §2.3.3: x_ref -> x with the position
/// feedback removed; input the error in m, output x in m) or the closed loop x_ref -> x (m).
/// `sum_pressure_closed = None` opens the sum-pressure loop in the open loop (as the article
/// analyses it) and follows the rig's `sum_pressure` key in the closed loop (as `step` and
/// `simulate` do).
fn loop_of(rig: &Rig, which: &str, sum_pressure_closed: Option<bool>) -> PyResult<StateSpace> {
    let plant = Plant::new(rig);
    match which {
        "open" => Ok(plant.open_loop(sum_pressure_closed.unwrap_or(false))),
        "closed" => Ok(plant.closed_loop(sum_pressure_closed.unwrap_or(rig.sum_pressure))),
        other => Err(err(format!(
            "loop = {other:?}: must be \"open\" or \"closed\""
        ))),
    }
}

/// A result of pumpcyl: the document the command line prints with `--json` (the presentation
/// layer builds it once for both front ends), every key an attribute and an item
/// (`r.beta_bar`, `r["beta_bar"]`), a run's signals as numpy arrays (themselves a `Result`:
/// `r.signals.x_mm`), and the whole as plain data, equal to the command line's JSON, with
/// `to_dict()`.
#[pyclass(module = "pumpcyl._pumpcyl", name = "Result", frozen)]
struct PyOutcome {
    /// What the result is (`Margins`, `Identification`, ...), for `repr`.
    kind: String,
    /// The fields.
    fields: Py<PyDict>,
}

impl PyOutcome {
    /// The result `kind` with the fields of the JSON document `value` (an object).
    fn of(py: Python<'_>, kind: &str, value: &serde_json::Value) -> PyResult<Self> {
        let fields = to_py(py, value)?
            .bind(py)
            .cast::<PyDict>()?
            .clone()
            .unbind();
        Ok(PyOutcome {
            kind: kind.to_string(),
            fields,
        })
    }

    /// The result `kind` of a serialisable value.
    fn of_value(py: Python<'_>, kind: &str, value: &impl serde::Serialize) -> PyResult<Self> {
        PyOutcome::of(py, kind, &serde_json::to_value(value).map_err(err)?)
    }

    /// This result with the columns under `key` (an object of number lists, if present) as
    /// numpy arrays, gathered in a `Result` of kind `kind`. A `null` sample is NaN.
    fn with_arrays(self, py: Python<'_>, key: &str, kind: &str) -> PyResult<Self> {
        let fields = self.fields.bind(py);
        if let Some(columns) = fields.get_item(key)? {
            let arrays = PyDict::new(py);
            for (name, values) in columns.cast::<PyDict>()? {
                let values: Vec<Option<f64>> = values.extract()?;
                let values: Vec<f64> = values.into_iter().map(|v| v.unwrap_or(f64::NAN)).collect();
                arrays.set_item(name, values.into_pyarray(py))?;
            }
            let block = PyOutcome {
                kind: kind.to_string(),
                fields: arrays.unbind(),
            };
            fields.set_item(key, Py::new(py, block)?)?;
        }
        Ok(self)
    }

    fn field<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.fields.bind(py).get_item(name)
    }
}

/// `v` as plain Python data, as `json.loads` of the command line's document gives it: a
/// `Result` as its dict, numpy arrays as lists, dicts and lists copied.
fn plain<'py>(v: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    let py = v.py();
    if let Ok(r) = v.cast::<PyOutcome>() {
        return Ok(r.get().to_dict(py)?.into_any());
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let out = PyDict::new(py);
        for (k, x) in d {
            out.set_item(k, plain(&x)?)?;
        }
        return Ok(out.into_any());
    }
    if let Ok(l) = v.cast::<PyList>() {
        let items = l.iter().map(|x| plain(&x)).collect::<PyResult<Vec<_>>>()?;
        return Ok(PyList::new(py, items)?.into_any());
    }
    if !v.is_instance_of::<PyString>() && v.hasattr("tolist")? {
        return v.call_method0("tolist");
    }
    Ok(v.clone())
}

#[pymethods]
impl PyOutcome {
    fn __getattr__<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        self.field(py, name)?.ok_or_else(|| {
            PyAttributeError::new_err(format!("{} has no field `{name}`", self.kind))
        })
    }

    fn __getitem__<'py>(&self, py: Python<'py>, key: &str) -> PyResult<Bound<'py, PyAny>> {
        self.field(py, key)?.ok_or_else(|| {
            pyo3::exceptions::PyKeyError::new_err(format!("{} has no field `{key}`", self.kind))
        })
    }

    fn __contains__(&self, py: Python<'_>, key: &str) -> PyResult<bool> {
        self.fields.bind(py).contains(key)
    }

    fn __len__(&self, py: Python<'_>) -> usize {
        self.fields.bind(py).len()
    }

    fn __iter__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        Ok(self
            .fields
            .bind(py)
            .keys()
            .into_any()
            .try_iter()?
            .into_any())
    }

    /// The field names, in the document's order.
    fn keys<'py>(&self, py: Python<'py>) -> Bound<'py, PyList> {
        self.fields.bind(py).keys()
    }

    /// The field values, in the document's order.
    fn values<'py>(&self, py: Python<'py>) -> Bound<'py, PyList> {
        self.fields.bind(py).values()
    }

    /// (name, value) pairs, in the document's order.
    fn items<'py>(&self, py: Python<'py>) -> Bound<'py, PyList> {
        self.fields.bind(py).items()
    }

    /// The field `key`, or `default` when the result has none.
    #[pyo3(signature = (key, default = None))]
    fn get<'py>(
        &self,
        py: Python<'py>,
        key: &str,
        default: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        Ok(self
            .field(py, key)?
            .or(default)
            .unwrap_or_else(|| py.None().into_bound(py)))
    }

    /// The whole result as plain data (dicts, lists, floats, None): what `json.loads` gives
    /// of the command line's `--json` document.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        Ok(plain(self.fields.bind(py).as_any())?.cast_into::<PyDict>()?)
    }

    /// The field `field` of every object in the list `key` as a numpy array of floats (`None`
    /// as NaN, `True`/`False` as 1/0): `select(...).column("options", "kp_max")`.
    fn column<'py>(
        &self,
        py: Python<'py>,
        key: &str,
        field: &str,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let list = self.__getitem__(py, key)?;
        let values = list
            .try_iter()?
            .map(|item| {
                let v = item?.get_item(field)?;
                Ok(if v.is_none() {
                    f64::NAN
                } else {
                    v.extract::<f64>()?
                })
            })
            .collect::<PyResult<Vec<f64>>>()?;
        Ok(values.into_pyarray(py))
    }

    /// Equal to another `Result` or a dict holding the same plain data.
    fn __eq__(&self, py: Python<'_>, other: &Bound<'_, PyAny>) -> PyResult<bool> {
        let mine = self.to_dict(py)?;
        if let Ok(r) = other.cast::<PyOutcome>() {
            return mine.eq(r.get().to_dict(py)?);
        }
        if other.is_instance_of::<PyDict>() {
            return mine.eq(plain(other)?);
        }
        Ok(false)
    }

    fn __dir__(&self, py: Python<'_>) -> PyResult<Vec<String>> {
        let mut names: Vec<String> = self.fields.bind(py).keys().extract()?;
        names.extend(["keys", "values", "items", "get", "to_dict", "column"].map(String::from));
        Ok(names)
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let fields: Vec<(String, Bound<'_, PyAny>)> = self
            .fields
            .bind(py)
            .iter()
            .map(|(k, v)| Ok((k.extract()?, v)))
            .collect::<PyResult<_>>()?;
        repr_of(&self.kind, fields)
    }
}

/// A field's value in a `repr`: a float to 4 significant digits, a text cut short, a list,
/// dict or array by its length (`<list of 4>`).
fn shown(v: &Bound<'_, PyAny>) -> PyResult<String> {
    if v.is_instance_of::<PyFloat>() {
        return v.call_method1("__format__", (".4g",))?.extract();
    }
    if v.is_instance_of::<PyString>() || v.is_instance_of::<PyInt>() || v.is_none() {
        return Ok(short_repr(v));
    }
    match v.len() {
        Ok(n) => Ok(format!("<{} of {n}>", v.get_type().name()?)),
        Err(_) => Ok(short_repr(v)),
    }
}

/// `Kind(name=value, ...)` over at most five lines: numbers and flags first, then lists, dicts
/// and arrays by their length, then texts; the fields that do not fit are named at the end
/// (`… also experiment, grids`), each readable as an attribute.
fn repr_of(kind: &str, fields: Vec<(String, Bound<'_, PyAny>)>) -> PyResult<String> {
    const WIDTH: usize = 96;
    const LINES: usize = 5;
    let rank = |v: &Bound<'_, PyAny>| match (v.is_instance_of::<PyString>(), v.len().is_ok()) {
        (true, _) => 2,
        (false, sized) => usize::from(sized),
    };
    let mut fields = fields;
    fields.sort_by_key(|(_, v)| rank(v));
    let mut lines = Vec::new();
    let mut line = format!("{kind}(");
    for (i, (k, v)) in fields.iter().enumerate() {
        let item = format!("{k}={}", shown(v)?);
        if i > 0 && line.len() + 2 + item.len() > WIDTH {
            if lines.len() + 1 == LINES {
                let rest: Vec<&str> = fields[i..].iter().map(|(k, _)| k.as_str()).collect();
                line.push_str(&format!(", … also {}", rest.join(", ")));
                break;
            }
            lines.push(format!("{line},"));
            line = " ".repeat(kind.len() + 1);
        } else if i > 0 {
            line.push_str(", ");
        }
        line.push_str(&item);
    }
    lines.push(format!("{line})"));
    Ok(lines.join("\n"))
}

/// A request's error as Python says it of the call `call`: an option out of range named as
/// its keyword (`step(step_mm=0.0): ...`), each cause after the one it explains.
fn request_err(call: &str, e: &anyhow::Error) -> PyErr {
    use pumpcyl::limits::LimitError;
    let parts: Vec<String> = (e.chain())
        .map(|cause| {
            if let Some(field) = cause.downcast_ref::<FieldError>() {
                return field.in_python(call);
            }
            match cause.downcast_ref::<LimitError>() {
                Some(LimitError::LongRun { .. }) => format!("{cause} (allow_long_run=True)"),
                _ => cause.to_string(),
            }
        })
        .collect();
    err(parts.join(": "))
}

/// Run the request `call` (`request`) with the GIL released, its progress shown as `progress`
/// asks ([`progress_reporter`]) over the work the request reports, Ctrl-C stopping it.
fn run_reporting<R>(
    py: Python<'_>,
    call: &'static str,
    request: &R,
    progress: Option<Py<PyAny>>,
) -> PyResult<R::Outcome>
where
    R: Request + Sync,
    R::Outcome: Send,
{
    let (total, unit) = request.work().unwrap_or((1, "steps"));
    let mut tick = progress_reporter(py, progress, call, unit, total)?;
    let work = |go_on: &(dyn Fn(u64) -> bool + Sync)| request.run(Hooks { tick: go_on });
    let outcome = run_interruptible(py, work, &mut tick)?.map_err(|e| request_err(call, &e))?;
    tick(py, u64::MAX)?;
    Ok(outcome)
}

/// Run the request `call` (`request`) with the GIL released.
fn run_request<R>(py: Python<'_>, call: &str, request: &R) -> PyResult<R::Outcome>
where
    R: Request + Sync,
    R::Outcome: Send,
{
    (py.detach(|| request.run(Hooks::none()))).map_err(|e| request_err(call, &e))
}

/// The outcome of the request `call` as a `Result` of `kind`, each of its warnings a
/// `UserWarning`.
fn document(
    py: Python<'_>,
    call: &str,
    kind: &str,
    outcome: &impl Document,
) -> PyResult<PyOutcome> {
    warn_each(py, outcome.warnings().to_vec())?;
    let doc = outcome.json().map_err(|e| request_err(call, &e))?;
    PyOutcome::of(py, kind, &doc)
}

/// Gain, phase and delay margins of the position loop (the article §2.3.3), every crossing,
/// closed-loop stability, the disk margin of skew `skew` with the sensitivity peaks, and the
/// same of the loop as the rig's PLC samples it (`sampled`): the command line's
/// `margins --json`, field for field (a `None` margin is infinite: no crossing of that kind).
#[pyfunction]
#[pyo3(signature = (rig, *, sum_pressure_closed = false, skew = 0.0))]
fn margins(
    py: Python<'_>,
    rig: &PyRig,
    sum_pressure_closed: bool,
    skew: f64,
) -> PyResult<PyOutcome> {
    let request = request::analysis::Margins {
        rig: rig.input(),
        sum_pressure_closed,
        skew,
    };
    document(
        py,
        "margins",
        "Margins",
        &run_request(py, "margins", &request)?,
    )
}

/// The poles of the position loop (open loop, unity position feedback, and the closed loop as
/// simulated where the sum-pressure loop is on), each pole's natural frequency and damping, as
/// `pumpcyl poles --json` prints them; on a single-pump rig also each mode's poles (`modes`)
/// beside the switching force (docs/circuits.md#modes-in-margins-and-poles).
#[pyfunction]
#[pyo3(signature = (rig, *, sum_pressure_closed = false))]
fn poles(py: Python<'_>, rig: &PyRig, sum_pressure_closed: bool) -> PyResult<PyOutcome> {
    let request = request::analysis::Poles {
        rig: rig.input(),
        sum_pressure_closed,
    };
    document(py, "poles", "Poles", &run_request(py, "poles", &request)?)
}

/// (A, B, C, D) of the open or closed loop (SI units; states as `pumpcyl model` lists them).
#[pyfunction]
#[pyo3(signature = (rig, r#loop = "open", *, sum_pressure_closed = None))]
fn state_space<'py>(
    py: Python<'py>,
    rig: &PyRig,
    r#loop: &str,
    sum_pressure_closed: Option<bool>,
) -> PyResult<Bound<'py, PyTuple>> {
    let sys = loop_of(&rig.rig, r#loop, sum_pressure_closed)?;
    PyTuple::new(
        py,
        [
            array2(py, &sys.a),
            array2(py, &sys.b),
            array2(py, &sys.c),
            array2(py, &sys.d),
        ],
    )
}

/// The names of the states, inputs and outputs of `state_space(rig, loop)`, as the MATLAB
/// export names them (`pumpcyl model --m`): states x, v, p1, p2, w1, w2, then tau1, tau2 and
/// z1, z2 where the rig's model has them; input e (open loop) or x_ref (closed loop); output x.
#[pyfunction]
#[pyo3(name = "_loop_names", signature = (rig, r#loop = "open"))]
fn loop_names(rig: &PyRig, r#loop: &str) -> PyResult<(Vec<String>, Vec<String>, Vec<String>)> {
    let outputs = loop_of(&rig.rig, r#loop, None)?.c.nrows();
    let view = Loop::of_rig(rig.rig.clone(), "", false)
        .view(r#loop == "closed", false)
        .map_err(err)?;
    let names = |ports: &[pumpcyl::loops::Port], n: usize| {
        ports.iter().take(n).map(|p| p.name.clone()).collect()
    };
    Ok((
        view.states.iter().map(|s| s.name.clone()).collect(),
        names(&view.inputs, usize::MAX),
        names(&view.outputs, outputs),
    ))
}

/// Magnitude (dB) and unwrapped phase (deg) of the loop at the frequencies `f_hz` (Hz,
/// positive, increasing; a single frequency gives arrays of one value).
#[pyfunction]
#[pyo3(signature = (rig, f_hz, r#loop = "open", *, sum_pressure_closed = None))]
fn bode<'py>(
    py: Python<'py>,
    rig: &PyRig,
    f_hz: &Bound<'py, PyAny>,
    r#loop: &str,
    sum_pressure_closed: Option<bool>,
) -> PyResult<Bound<'py, PyTuple>> {
    let arg = Arg::new("bode", "f_hz");
    let scalar = |e| f_hz.extract::<f64>().map(|x| vec![x]).map_err(|_| e);
    let f = floats(&arg, f_hz).or_else(scalar)?;
    if f.is_empty() || f.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
        return Err(arg.error(f_hz, "frequencies must be finite and > 0"));
    }
    if f.windows(2).any(|w| w[1] <= w[0]) {
        return Err(arg.error(f_hz, "frequencies must strictly increase"));
    }
    let sys = loop_of(&rig.rig, r#loop, sum_pressure_closed)?;
    let b = py.detach(|| lti::bode(&sys, &f)).map_err(err)?;
    PyTuple::new(py, [array1(py, &b.mag_db), array1(py, &b.phase_deg)])
}

// ---------------------------------------------------------------------------------------------
// Time domain

/// Warn (UserWarning) of each line of `lines`, and return them.
fn warn_each(py: Python<'_>, lines: Vec<String>) -> PyResult<Vec<String>> {
    let category = py.get_type::<PyUserWarning>();
    for line in &lines {
        PyErr::warn(py, category.as_any(), &CString::new(line.as_str())?, 1)?;
    }
    Ok(lines)
}

/// The warnings of a run of `rig` that `what` produced as signals `s`, each a UserWarning:
/// its predicted position leaving the stroke (docs/emulator.md#end-stops), returned as the
/// command line's document lists it, and the drive ratings it exceeds
/// (docs/simulation.md#drive-ratings), which the document holds as `over_ratings`.
fn run_warnings(
    py: Python<'_>,
    what: &str,
    rig: &Rig,
    s: &Signals,
    over: &[response::OverRating],
) -> PyResult<Vec<String>> {
    let stroke: Vec<String> = response::stroke_excursion(rig, s)
        .map(|e| e.to_string())
        .into_iter()
        .collect();
    warn_each(
        py,
        pumpcyl_present::documents::rating_warning_lines(what, over),
    )?;
    warn_each(py, stroke)
}

/// Simulate the closed loop (exact zero-order hold, docs/simulation.md) driven by `x_ref_mm`
/// sampled at `t_s` and held between samples, from the loop's rest under x_ref_mm[0]: the
/// piston off it by the rest offset, the pressures and motor speeds of that rest
/// (docs/simulation.md#the-rest-under-load). An unstable closed loop is an error, so is a
/// reference outside the stroke (as the command line's `simulate`); a predicted position
/// outside it or a drive rating exceeded warns (UserWarning). A `Result` with `rig`, `circuit`,
/// `signals` (numpy arrays), `rest_offset_mm`, `over_ratings` and `warnings`.
#[pyfunction]
fn simulate(
    py: Python<'_>,
    rig: &PyRig,
    t_s: &Bound<'_, PyAny>,
    x_ref_mm: &Bound<'_, PyAny>,
) -> PyResult<PyOutcome> {
    let arg = |name| Arg::new("simulate", name);
    let (t, r) = (
        floats(&arg("t_s"), t_s)?,
        floats(&arg("x_ref_mm"), x_ref_mm)?,
    );
    let rec = Record::from_arrays("simulate", &t, &r, &r).map_err(err)?;
    let (lo, hi) = rec.reference_range_mm();
    rig.rig
        .check_reference(lo, hi)
        .map_err(|e| err(format!("simulate: x_ref_mm: {e}")))?;
    // the loop at rest under its first reference: the piston stands off it by the rest offset
    // (docs/simulation.md#the-rest-under-load)
    let mut base = Baseline::of_rig(&rig.rig);
    let offset_mm = base.x_ref_mm - base.x_mm;
    base.x_ref_mm = r[0];
    base.x_mm = r[0] - offset_mm;
    let (name, from, rig) = (rig.__repr__(), rig, rig.rig.clone());
    let (s, over, signals) = py
        .detach(|| {
            let s = response::simulate(&rig, &t, &r, &base)?;
            let over = response::signals_over_ratings(&rig, &s);
            let signals = pumpcyl_present::documents::signals_json(&s);
            Ok::<_, lti::LtiError>((s, over, signals))
        })
        .map_err(err)?;
    let warnings = run_warnings(py, "simulate", &rig, &s, &over)?;
    let doc = serde_json::json!({
        "rig": name,
        "circuit": rig.circuit.name(),
        "signals": signals,
        "rest_offset_mm": offset_mm,
        "over_ratings": over,
        "warnings": warnings,
    });
    PyOutcome::of(py, "Simulation", &from.document(doc))?.with_arrays(py, "signals", "Signals")
}

/// Closed-loop response to a position step of `step_mm` (mm) from the operating point x0,
/// sampled at `rate_hz` (Hz) for `duration_s` (s): the command line's `step --json` (`rig`,
/// `circuit`, `step_mm`, `metrics`, `over_ratings`, `signals` as numpy arrays, `warnings`). A step
/// smaller than 0.05 mm in size warns (UserWarning): `step_mm` is in millimetres, not metres;
/// so does a predicted position outside the stroke (docs/emulator.md#end-stops) or a drive
/// rating exceeded.
#[pyfunction]
#[pyo3(signature = (rig, step_mm = 5.0, *, duration_s = 4.0, rate_hz = 100.0))]
fn step(
    py: Python<'_>,
    rig: &PyRig,
    step_mm: f64,
    duration_s: f64,
    rate_hz: f64,
) -> PyResult<PyOutcome> {
    let request = request::time::Step {
        rig: rig.input(),
        step_mm,
        duration_s,
        rate_hz,
        compare: Vec::new(),
    };
    let outcome = run_request(py, "step", &request)?;
    let s = document(py, "step", "Step", &outcome)?;
    warn_each(py, outcome.rating_warnings())?;
    s.with_arrays(py, "signals", "Signals")
}

/// Sinusoidal tracking about x0 (docs/simulation.md#tracking-metrics): a sine of `freq_hz` (Hz)
/// and `amp_mm` (mm), or the article's three (0.1 Hz ±50 mm, 0.2 Hz ±35 mm, 0.25 Hz ±20 mm)
/// when both are `None`, over `periods` whole periods sampled at `rate_hz` (Hz); the metrics
/// are the periodic steady state. The command line's `track --json` (`rig`, `circuit`,
/// `cases`: `label`, `metrics`, `over_ratings` each; `unstable`, `warnings`). A predicted
/// position outside the stroke warns (UserWarning).
#[pyfunction]
#[pyo3(signature = (rig, freq_hz = None, amp_mm = None, *, periods = 3.0, rate_hz = 100.0))]
fn track(
    py: Python<'_>,
    rig: &PyRig,
    freq_hz: Option<f64>,
    amp_mm: Option<f64>,
    periods: f64,
    rate_hz: f64,
) -> PyResult<PyOutcome> {
    let waves =
        match (freq_hz, amp_mm) {
            (Some(f), Some(a)) => vec![(f, a)],
            (None, None) => Vec::new(),
            _ => return Err(err(
                "track: give freq_hz and amp_mm together, or neither for the article's three sines",
            )),
        };
    let request = request::time::Track {
        rig: rig.input(),
        waves,
        periods,
        rate_hz,
        compare: Vec::new(),
    };
    let outcome = run_request(py, "track", &request)?;
    let t = document(py, "track", "Tracking", &outcome)?;
    warn_each(py, outcome.rating_warnings())?;
    Ok(t)
}

// ---------------------------------------------------------------------------------------------
// Identification

/// One record to fit, from arrays: time (s), reference and measured position (mm), with the
/// keys of an experiment file's `[[dataset]]`: the experiment's position gain and mass, the end
/// of the fit window (s) a step record needs, and `kind` (`"step"` or `"sweep"`; absent, the
/// frequency method tells them by the reference).
#[pyclass(module = "pumpcyl._pumpcyl", name = "Dataset", frozen)]
struct PyDataset {
    record: Record,
    entry: ident::DatasetEntry,
}

#[pymethods]
impl PyDataset {
    #[new]
    #[pyo3(signature = (
        t_s, x_ref_mm, x_mm, *, kp, mass_kg, fit_end_s = None, kind = None, sweep = None,
        name = "dataset"
    ))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        t_s: &Bound<'_, PyAny>,
        x_ref_mm: &Bound<'_, PyAny>,
        x_mm: &Bound<'_, PyAny>,
        kp: f64,
        mass_kg: f64,
        fit_end_s: Option<f64>,
        kind: Option<String>,
        sweep: Option<&Bound<'_, PyAny>>,
        name: &str,
    ) -> PyResult<Self> {
        let arg = |name| Arg::new("Dataset", name);
        let (t, r, x) = (
            floats(&arg("t_s"), t_s)?,
            floats(&arg("x_ref_mm"), x_ref_mm)?,
            floats(&arg("x_mm"), x_mm)?,
        );
        let record = Record::from_arrays(name, &t, &r, &x).map_err(err)?;
        Ok(PyDataset {
            record,
            entry: ident::DatasetEntry {
                file: name.to_string(),
                kp,
                mass_kg,
                fit_end_s,
                kind,
                sweep: sweep.map(sweep_of).transpose()?,
            },
        })
    }

    fn __repr__(&self) -> String {
        let e = &self.entry;
        let optional =
            |k: &str, v: Option<String>| v.map_or(String::new(), |v| format!(", {k}={v}"));
        format!(
            "Dataset(name={:?}, samples={}, kp={}, mass_kg={}{}{})",
            e.file,
            self.record.len(),
            e.kp,
            e.mass_kg,
            optional("fit_end_s", e.fit_end_s.map(|v| v.to_string())),
            optional("kind", e.kind.as_ref().map(|k| format!("{k:?}")))
        )
    }
}

/// A sweep's keys from a dict (those of an experiment file's `[dataset.sweep]`), read through
/// JSON so that the same serde definition refuses an unknown key.
fn sweep_of(v: &Bound<'_, PyAny>) -> PyResult<pumpcyl::frf::SweepSpec> {
    let text: String = v
        .py()
        .import("json")?
        .call_method1("dumps", (v,))?
        .extract()?;
    serde_json::from_str(&text).map_err(|e| err(format!("Dataset(sweep=...): {e}")))
}

impl PyDataset {
    /// This dataset on `rig`, prepared for `method` ([`ident::DatasetEntry::load`]); the error
    /// names the dataset and the key.
    fn load(&self, method: ident::Method, rig: &Rig) -> PyResult<ident::Loaded> {
        let e = &self.entry;
        e.load(self.record.clone(), method, rig).map_err(|(k, m)| {
            let key = k.map_or(String::new(), |k| format!(", {k}"));
            err(format!("Dataset {:?}{key}: {m}", e.file))
        })
    }
}

/// Run `work` (given a progress callback returning "go on") on a worker thread with the GIL
/// released, while this thread watches for Ctrl-C (the search stops and KeyboardInterrupt is
/// raised) and reports progress through `tick(done)`.
fn run_interruptible<T: Send>(
    py: Python<'_>,
    work: impl FnOnce(&(dyn Fn(u64) -> bool + Sync)) -> T + Send,
    tick: &mut (dyn FnMut(Python<'_>, u64) -> PyResult<()> + Send),
) -> PyResult<T> {
    let done = AtomicU64::new(0);
    let stop = AtomicBool::new(false);
    let mut interrupt: Option<PyErr> = None;
    let out = py.detach(|| {
        std::thread::scope(|s| {
            let (tx, rx) = std::sync::mpsc::channel();
            let (done, stop) = (&done, &stop);
            let worker = s.spawn(move || {
                let r = work(&|n| {
                    done.fetch_add(n, Ordering::Relaxed);
                    !stop.load(Ordering::Relaxed)
                });
                let _ = tx.send(());
                r
            });
            let timeout = Duration::from_millis(50);
            while let Err(RecvTimeoutError::Timeout) = rx.recv_timeout(timeout) {
                let checked = Python::attach(|py| {
                    tick(py, done.load(Ordering::Relaxed))?;
                    py.check_signals()
                });
                if let Err(e) = checked {
                    stop.store(true, Ordering::Relaxed);
                    interrupt.get_or_insert(e);
                }
            }
            worker
                .join()
                .unwrap_or_else(|p| std::panic::resume_unwind(p))
        })
    });
    match interrupt {
        Some(e) => Err(e),
        None => Ok(out),
    }
}

/// A grid from a dict {beta_bar, viscous_friction_ns_per_m, c12_m5_per_ns} of lists, checked.
fn grid_of(name: &str, value: &Bound<'_, PyAny>) -> PyResult<Grid> {
    let grid: Grid = from_py(&Arg::new("identify", name), value)?;
    grid.validate(name).map_err(err)?;
    Ok(grid)
}

/// The standstill point from a dict {w1_rpm, w2_rpm, p1_bar}, checked.
fn standstill_of(value: &Bound<'_, PyAny>) -> PyResult<Standstill> {
    let s: Standstill = from_py(&Arg::new("identify", "standstill"), value)?;
    s.validate().map_err(err)?;
    Ok(s)
}

/// Grid identification of beta (bar), b (N·s/m) and c12 (m⁵/(N·s)) (the article §2.4.4),
/// with c1, c2 from the standstill point (the article §2.4.3) and Nelder-Mead refinement.
///
/// Either `experiment`, an experiment TOML file as `pumpcyl identify` reads, or
/// `datasets=[Dataset(...)]` with `standstill=dict(w1_rpm=..., w2_rpm=..., p1_bar=...)` (rpm,
/// rpm, bar gauge) and `rig` (default: the article's). `grid` and `refined_grid` are dicts
/// {beta_bar, viscous_friction_ns_per_m, c12_m5_per_ns} of lists (default: the file's, else the
/// first centred on the rig's values and the second on the first stage's best;
/// docs/identification.md#the-two-grids); `refined_grid=False` skips the second stage.
/// `auto_refine`, `local_refinement` and `threshold_mm2` (mm^2) override the file; `top` is the
/// length of the top list. Work beyond 10^9 candidate-samples (hours) is refused unless
/// `allow_long_run=True`. The search runs with the GIL released; Ctrl-C stops it
/// (KeyboardInterrupt). `progress=True` prints progress on stderr; a callable gets
/// `(done, total)` candidates. `method="frequency"` (or the file's `method = "frequency"`)
/// fits the experiment's sweep records by their frequency response, with any step records
/// beside them (docs/identification.md#grey-box-fit-to-a-frequency-response), `grid` its grid;
/// the document holds the 95 % profile-likelihood `intervals` too.
#[pyfunction]
#[pyo3(signature = (
    experiment = None, *, datasets = None, standstill = None, rig = None, grids = None,
    grid = None, refined_grid = None, auto_refine = None, local_refinement = None,
    threshold_mm2 = None, top = 20, progress = None, allow_long_run = false, shard = None,
    uncertainty = false, confidence = 0.95, method = None
))]
#[allow(clippy::too_many_arguments)]
fn identify(
    py: Python<'_>,
    experiment: Option<PathBuf>,
    datasets: Option<Vec<Bound<'_, PyDataset>>>,
    standstill: Option<&Bound<'_, PyAny>>,
    rig: Option<&PyRig>,
    grids: Option<&str>,
    grid: Option<&Bound<'_, PyAny>>,
    refined_grid: Option<&Bound<'_, PyAny>>,
    auto_refine: Option<bool>,
    local_refinement: Option<bool>,
    threshold_mm2: Option<f64>,
    top: usize,
    progress: Option<Py<PyAny>>,
    allow_long_run: bool,
    shard: Option<(usize, usize)>,
    uncertainty: bool,
    confidence: f64,
    method: Option<&str>,
) -> PyResult<Py<PyAny>> {
    let method = method_of(method)?;
    let source = match (experiment, datasets) {
        (Some(path), None) => {
            if standstill.is_some() || rig.is_some() {
                return Err(err(
                    "standstill and rig come from the experiment file: give either the file or datasets",
                ));
            }
            let exp =
                Experiment::load_as(&pumpcyl::source_files::Disk, &path, method).map_err(err)?;
            Source::Experiment(Box::new(exp))
        }
        (None, Some(sets)) => {
            Source::Datasets(Box::new(datasets_of(&sets, standstill, rig, method)?))
        }
        (Some(_), Some(_)) => {
            return Err(err(
                "give either `experiment` (an experiment TOML file) or `datasets`, not both",
            ))
        }
        (None, None) => {
            return Err(err(
                "give `experiment` (an experiment TOML file) or `datasets=[Dataset(...)]` \
                 with `standstill`; neither was given",
            ))
        }
    };
    let frequency = match &source {
        Source::Experiment(exp) => exp.method == ident::Method::Frequency,
        Source::Datasets(d) => d.method == ident::Method::Frequency,
    };
    let search = Search {
        article_grids: article_grids(grids)?,
        grid: grid.map(|g| grid_of("grid", g)).transpose()?,
        refined_grid: refined_grid.map(refined_of).transpose()?,
        auto_refine,
        local_refinement,
        threshold_mm2,
        top,
    };
    let request = Identify {
        source,
        search,
        shard,
        // a frequency-domain fit takes seconds: its intervals always come with it
        uncertainty: (uncertainty || frequency).then_some(confidence),
        allow_long_run,
        files: &pumpcyl::source_files::Disk,
    };
    let outcome = run_reporting(py, "identify", &request, progress)?;
    if let Some(part) = outcome.partial() {
        let text = serde_json::to_string(part).map_err(err)?;
        return Ok(PyString::new(py, &text).into_any().unbind());
    }
    Ok(Py::new(py, document(py, "identify", "Identification", &outcome)?)?.into_any())
}

/// `grids`: `"article"` names the article's two (§2.4), as an experiment file's `grids` key.
fn article_grids(grids: Option<&str>) -> PyResult<bool> {
    match grids {
        None => Ok(false),
        Some("article") => Ok(true),
        Some(other) => Err(err(format!(
            "grids=\"{other}\": the only named grids are \"article\""
        ))),
    }
}

/// `refined_grid`: a grid, or `False` for no second stage.
fn refined_of(g: &Bound<'_, PyAny>) -> PyResult<Option<ident::SecondGrid>> {
    if g.is_instance_of::<PyBool>() && !g.extract::<bool>()? {
        return Ok(None);
    }
    Ok(Some(grid_of("refined_grid", g)?.into()))
}

/// The fitting method named, if any.
fn method_of(name: Option<&str>) -> PyResult<Option<ident::Method>> {
    name.map(|m| {
        ident::Method::named(m)
            .ok_or_else(|| err(format!("method=\"{m}\": give \"time\" or \"frequency\"")))
    })
    .transpose()
}

/// The records `sets` on `rig` (default: the article's) at the `standstill` point, each loaded
/// for `method` (default: the time domain).
fn datasets_of(
    sets: &[Bound<'_, PyDataset>],
    standstill: Option<&Bound<'_, PyAny>>,
    rig: Option<&PyRig>,
    method: Option<ident::Method>,
) -> PyResult<Datasets> {
    let rig = rig.map_or_else(
        || RigInput::default_named("the article's rig"),
        PyRig::input,
    );
    let standstill = standstill_of(
        standstill
            .ok_or_else(|| err("standstill: give dict(w1_rpm=..., w2_rpm=..., p1_bar=...)"))?,
    )?;
    if sets.is_empty() {
        return Err(err("datasets: needs at least one Dataset"));
    }
    let method = method.unwrap_or(ident::Method::Time);
    let sets = (sets.iter())
        .map(|d| d.get().load(method, &rig.rig))
        .collect::<PyResult<Vec<_>>>()?;
    Ok(Datasets {
        rig,
        sets,
        standstill,
        method,
    })
}

/// Refuse, before any shard runs, a split of the grids of the experiment file `experiment`
/// into `shards` that no shard could run (docs/identification.md#sharding): more shards than
/// the limit or than the smaller grid's candidates, or a second grid not fixed in advance.
/// `pumpcyl.distributed.identify` asks it once rather than have every shard refuse.
#[pyfunction]
#[pyo3(name = "_check_shards")]
fn check_shards(py: Python<'_>, experiment: PathBuf, shards: usize) -> PyResult<()> {
    py.detach(|| {
        let exp = Experiment::load(&experiment)?;
        ident::shards::check_label(&exp, (1, shards))?;
        let request = ident::Request {
            shard: Some((1, shards)),
            // each shard checks its own work against the limit
            allow_long_run: true,
            ..exp.request(exp.options())
        };
        request.check()
    })
    .map_err(err)
}

/// Merge the partial results of `identify(experiment, shard=(i, n))` for i = 1..n (each the
/// JSON text it returned, in any order) into the identification of one unsharded run, as
/// `pumpcyl identify-merge --json` does, with the same checks (docs/identification.md#sharding):
/// refused when a shard is missing or given twice, the shards come from different runs,
/// options or experiment contents, or a partial result was edited. The experiment file is read
/// again from the path the shards name. `seconds` is the shards' search time added up, plus
/// the merge's own. Runs with the GIL released.
#[pyfunction]
fn identify_merge(py: Python<'_>, shards: Vec<Bound<'_, PyAny>>) -> PyResult<PyOutcome> {
    let mut parts = Vec::with_capacity(shards.len());
    for (k, text) in shards.iter().enumerate() {
        let arg = Arg::new("identify_merge", &format!("shards[{k}]"));
        let text: String = text.extract().map_err(|_| {
            arg.error(
                text,
                "a shard's JSON text, as identify(shard=...) returns it",
            )
        })?;
        let part: ident::shards::Partial = serde_json::from_str(&text).map_err(|e| {
            err(format!(
                "identify_merge({}): not a partial result: {e}",
                arg.name
            ))
        })?;
        parts.push((PathBuf::from(&arg.name), part));
    }
    let request = request::identify::Merge {
        parts,
        files: &pumpcyl::source_files::Disk,
    };
    let outcome = run_request(py, "identify_merge", &request)?;
    document(py, "identify_merge", "Identification", &outcome)
}

/// The closed-loop frequency response of a sweep record (docs/identification.md#frequency-response-from-a-sweep)
/// with its coherence and 95 % band at each frequency, and `rig`'s model beside it (default:
/// the article's rig), as `pumpcyl frf RECORD.csv --json` gives it: periodic sweeps found in
/// the record are averaged over their periods, anything else by Welch's method (`segment_s`,
/// s, its segment length).
#[pyfunction]
#[pyo3(signature = (record, *, rig = None, segment_s = None))]
fn frf(
    py: Python<'_>,
    record: PathBuf,
    rig: Option<&PyRig>,
    segment_s: Option<f64>,
) -> PyResult<PyOutcome> {
    let request = request::frf::Frf {
        rig: rig.map_or_else(|| RigInput::default_named("Rig()"), PyRig::input),
        record: Record::read(&record).map_err(err)?,
        excitation: None,
        segment_s,
    };
    let outcome = run_request(py, "frf", &request)?;
    document(py, "frf", "FrequencyResponse", &outcome)
}

/// Whether Python's `sys.stderr` is a terminal (a notebook's or a pipe's is not).
fn stderr_is_terminal(py: Python<'_>) -> bool {
    let isatty = || -> PyResult<bool> {
        py.import("sys")?
            .getattr("stderr")?
            .call_method0("isatty")?
            .extract()
    };
    isatty().unwrap_or(false)
}

/// The line of `what`'s progress, `identify: 1200/12000 candidates`.
fn progress_line(what: &str, unit: &str, done: u64, total: u64) -> String {
    format!("{what}: {done}/{total} {unit}")
}

/// Progress of `what` over `total` `unit`s (`identify`, `select`, `design`): nothing, lines on
/// `sys.stderr` (`progress=True`), or a callable `progress(done, total)`. On a terminal the
/// line is redrawn in place; elsewhere (a pipe, a notebook) a whole line is written at each
/// tenth of the work, never carriage returns run together. `tick(py, u64::MAX)` marks the end.
#[allow(clippy::type_complexity)]
fn progress_reporter(
    py: Python<'_>,
    progress: Option<Py<PyAny>>,
    what: &'static str,
    unit: &'static str,
    total: u64,
) -> PyResult<Box<dyn FnMut(Python<'_>, u64) -> PyResult<()> + Send>> {
    let Some(p) = progress else {
        return Ok(Box::new(|_, _| Ok(())));
    };
    let as_bool = p.bind(py).is_instance_of::<PyBool>();
    if as_bool && !p.bind(py).extract::<bool>()? {
        return Ok(Box::new(|_, _| Ok(())));
    }
    let terminal = stderr_is_terminal(py);
    const PARTS: u64 = 10;
    let mut last = u64::MAX - 1;
    let mut last_part = u64::MAX;
    Ok(Box::new(move |py, done| {
        let end = done == u64::MAX;
        let done = if end { total } else { done.min(total) };
        if done == last && !end {
            return Ok(());
        }
        last = done;
        if !as_bool {
            p.call1(py, (done, total))?;
            return Ok(());
        }
        let line = progress_line(what, unit, done, total);
        let text = match (terminal, end) {
            (true, false) => format!("\r{line}"),
            (true, true) => format!("\r{line}\n"),
            (false, _) => {
                let part = (done * PARTS).checked_div(total).unwrap_or(PARTS);
                if part == last_part || (part == PARTS && !end) {
                    return Ok(());
                }
                last_part = part;
                format!("{line}\n")
            }
        };
        let stderr = py.import("sys")?.getattr("stderr")?;
        stderr.call_method1("write", (text,))?;
        stderr.call_method0("flush")?;
        Ok(())
    }))
}

// ---------------------------------------------------------------------------------------------
/// Experiment advice (docs/identification.md, "Experiment advice"): identify the records of
/// `experiment` (a TOML file as for `pumpcyl identify`), then compare candidate further
/// records (the TOML file `candidates`, else the default steps, sinusoids and gains) by the
/// interval widths of beta, b and c12 expected after adding each, at `confidence`: the
/// command line's `advise --json` (point, noise_std_mm, current, candidates ranked best first,
/// skipped, and keyed by parameter name: `best_for` {parameter: label} and
/// `ranking_by_parameter` {parameter: [{label, log_std, interval, width, relative_width}, ...]
/// best first}). `budget_s` weighs every candidate at that recording time (its record counted
/// budget/length times, longer ones skipped), as `advise --budget-s`. `levels`, experiments
/// at other pressure levels, join the experiment's own in `pressure_levels` (the family of
/// beta(p) models fitted to them and the next level to record, as `advise --level`;
/// docs/bulk-modulus.md#several-pressure-levels). Runs with the GIL released.
#[pyfunction]
#[pyo3(signature = (experiment, *, confidence = 0.95, candidates = None, budget_s = None, levels = None))]
fn advise(
    py: Python<'_>,
    experiment: PathBuf,
    confidence: f64,
    candidates: Option<PathBuf>,
    budget_s: Option<f64>,
    levels: Option<Vec<PathBuf>>,
) -> PyResult<PyOutcome> {
    let request = request::advise::Advise {
        experiment: Experiment::load(&experiment).map_err(err)?,
        candidates,
        confidence,
        budget_s,
        files: &pumpcyl::source_files::Disk,
        levels: (levels.unwrap_or_default().iter())
            .map(|p| Experiment::load(p).map_err(err))
            .collect::<PyResult<Vec<_>>>()?,
    };
    let outcome = run_request(py, "advise", &request)?;
    document(py, "advise", "Advice", &outcome)
}

// The article workflow

/// The article's workflow on the embedded emulated records (the library's
/// `pumpcyl_present::reproduce`, as `pumpcyl reproduce` runs it): with `out`, the result folder
/// (report.html, summary.json, figures/, records/, identification/) written whole or not at
/// all; returns summary.json as a `Result`. Runs with the GIL released; Ctrl-C stops it and raises
/// KeyboardInterrupt; `progress=True` prints each step on `sys.stderr`. Files of yours in `out`
/// are kept (a warning names them); `force=True` writes over one at a path of the result, or
/// into a non-empty folder that holds no earlier result (docs/formats.md#result-folders).
#[pyfunction]
#[pyo3(signature = (out = None, *, progress = false, force = false))]
fn reproduce(
    py: Python<'_>,
    out: Option<PathBuf>,
    progress: bool,
    force: bool,
) -> PyResult<PyOutcome> {
    let step = std::sync::Mutex::new((0usize, String::new()));
    let mut shown = 0usize;
    let mut tick = |py: Python<'_>, _done: u64| -> PyResult<()> {
        let (k, what) = step.lock().map(|g| g.clone()).unwrap_or_default();
        if progress && k != shown {
            shown = k;
            let line = format!("[{k}/{}] {what}\n", pumpcyl_present::reproduce::STEPS);
            let stderr = py.import("sys")?.getattr("stderr")?;
            stderr.call_method1("write", (line,))?;
        }
        Ok(())
    };
    let result = run_interruptible(
        py,
        |go_on| {
            let on_step = |k: usize, _n: usize, what: &str| {
                if let Ok(mut g) = step.lock() {
                    *g = (k, what.to_string());
                }
            };
            let on_candidates = |n: u64, _total: u64| go_on(n);
            let r = pumpcyl_present::reproduce::reproduce(
                &pumpcyl_present::reproduce::ReproduceOptions {
                    on_step: Some(&on_step),
                    on_candidates: Some(&on_candidates),
                },
            )
            .map_err(|e| format!("{e:#}"))?;
            let protected = pumpcyl_present::files::Protected::none().forcing(force);
            let done = match &out {
                Some(dir) => r
                    .write_with(dir, &protected)
                    .map_err(|e| format!("{e:#}"))?,
                None => Default::default(),
            };
            Ok::<_, String>((r.summary, done))
        },
        &mut tick,
    )?
    .map_err(err)?;
    let (summary, done) = result;
    let warnings = py.import("warnings")?;
    for note in done.notes() {
        let dir = out.as_deref().unwrap_or(std::path::Path::new("")).display();
        warnings.call_method1("warn", (format!("{dir}: {note}"),))?;
    }
    PyOutcome::of_value(py, "Summary", &summary)
}

// Bulk modulus and design

/// Gas fraction X that gives `beta_bar` (bar) at mean pressure `p_mean_bar` (bar), with pure
/// oil of `beta_oil_bar` (bar) (the article §3.1).
#[pyfunction]
#[pyo3(signature = (beta_bar, p_mean_bar, *, beta_oil_bar = 17000.0))]
fn gas_fraction(beta_bar: f64, p_mean_bar: f64, beta_oil_bar: f64) -> PyResult<f64> {
    pumpcyl::bulk::gas_fraction(beta_bar, p_mean_bar, beta_oil_bar).map_err(err)
}

// the signatures above show the oil's modulus as a number: it must stay the library's
const _: () = assert!(pumpcyl::bulk::BETA_OIL_BAR == 17000.0);

/// Effective bulk modulus (bar) at mean pressure `p_bar` (bar) for gas fraction `x` (0 to 1).
#[pyfunction]
#[pyo3(signature = (x, p_bar, *, beta_oil_bar = 17000.0))]
fn effective_beta(py: Python<'_>, x: f64, p_bar: f64, beta_oil_bar: f64) -> PyResult<f64> {
    let arg = |name| Arg::new("effective_beta", name);
    let (positive, rule) = (
        |v: f64| v.is_finite() && v > 0.0,
        "must be a finite value > 0",
    );
    let fraction = (0.0..=1.0).contains(&x);
    arg("x").check(py, x, fraction, "must be a gas fraction from 0 to 1")?;
    arg("p_bar").check(py, p_bar, positive(p_bar), rule)?;
    arg("beta_oil_bar").check(py, beta_oil_bar, positive(beta_oil_bar), rule)?;
    Ok(pumpcyl::bulk::effective_beta(x, p_bar, beta_oil_bar))
}

/// A record from the nonlinear rig emulator (docs/emulator.md), as `pumpcyl emulate --json`:
/// `experiment` "step" (from `from_mm` to `to_mm`, default x0 to x0 + 10 mm, at `at_s`),
/// "sine" (`amplitude_mm`, `freq_hz` from `at_s`), "standstill" or "drive-step" (drive
/// `motor` to `to_rpm`); `duration_s` and `rate_hz` (the PLC's) default to the experiment's.
/// `rig` None takes the emulator's own rig (the article's rig with the emulator's effects),
/// keyword `overrides` set its keys as `--set` does; `effects=False` switches every emulator
/// effect off, `noise=False` the sensor noise (`seed` seeds it). Records beyond the work limit
/// (their controller steps, or their integrator's work counted as they run:
/// docs/emulator.md#the-work-limit) run only with `allow_long_run=True`. A `Result` with `experiment`, `rig`, `samples`,
/// `basis` (what the emulator used, in words), `warnings` (each also a UserWarning),
/// `end_stop` and `columns`, the record's columns as numpy arrays (docs/formats.md#record-csv);
/// with `energy=True` also `energy`, the power account integrated over the record
/// (docs/energy.md#over-a-run), as `emulate --energy --json`.
#[pyfunction]
#[pyo3(signature = (
    experiment, rig = None, *, from_mm = None, to_mm = None, at_s = 0.5, amplitude_mm = 20.0,
    freq_hz = 0.25, motor = 1, to_rpm = 500.0, duration_s = None, rate_hz = None, seed = 1,
    noise = true, effects = true, allow_long_run = false, energy = false, **overrides
))]
#[allow(clippy::too_many_arguments)]
fn emulate(
    py: Python<'_>,
    experiment: &str,
    rig: Option<&PyRig>,
    from_mm: Option<f64>,
    to_mm: Option<f64>,
    at_s: f64,
    amplitude_mm: f64,
    freq_hz: f64,
    motor: usize,
    to_rpm: f64,
    duration_s: Option<f64>,
    rate_hz: Option<f64>,
    seed: u64,
    noise: bool,
    effects: bool,
    allow_long_run: bool,
    energy: bool,
    overrides: Option<&Bound<'_, PyDict>>,
) -> PyResult<PyOutcome> {
    use pumpcyl_present::emulated::{ExperimentKind, Request};
    let kind = ExperimentKind::named(experiment).ok_or_else(|| {
        err(format!(
            "emulate(experiment='{experiment}'): \"step\", \"sine\", \"drive-step\" or \"standstill\""
        ))
    })?;
    let (base, origin) = emulator_rig(rig, effects)?;
    let base = base.with("emulate", overrides)?;
    let request = request::emulate::Emulate {
        rig: RigInput {
            name: origin,
            ..base.input()
        },
        effects,
        record: Request {
            experiment: kind,
            from_mm,
            to_mm,
            at_s,
            amplitude_mm: Some(amplitude_mm),
            freq_hz,
            motor,
            to_rpm,
            duration_s,
            rate_hz,
            seed,
            noise,
            sweep: None,
            energy,
        },
        allow_long_run,
    };
    // Ctrl-C stops the run at its next progress report
    let outcome = run_reporting(py, "emulate", &request, None)?;
    document(py, "emulate", "Emulated", &outcome)?.with_arrays(py, "columns", "Columns")
}

/// The rig an emulating call runs on and its name: `rig` as given, or the emulated article rig
/// (effects on) or the article's (off), as the command line's `emulate` takes it.
fn emulator_rig(rig: Option<&PyRig>, effects: bool) -> PyResult<(PyRig, String)> {
    Ok(match rig {
        Some(r) => (r.clone(), r.__repr__()),
        None => (
            PyRig {
                rig: pumpcyl::fmu::default_rig(pumpcyl::fmu::ModelKind::Emulator, effects)
                    .map_err(err)?,
                defaulted: None,
            },
            "the emulated article rig".to_string(),
        ),
    })
}

/// Write the rig emulator or the linear model as an FMU (FMI 2.0 Co-Simulation, Linux x86-64;
/// docs/fmu.md), as `pumpcyl fmu` does: `model` "emulator" or "linear"; `controller`
/// "article" (the input is the position reference) or "external" (the motor speed commands are
/// the inputs; the linear model's open loop); `effects` the emulator's effects on or off.
/// `rig` None takes the emulator's own rig (as `pumpcyl emulate`) or the article's (linear).
/// `energy` adds the emulator's energy outputs (docs/fmu.md#energy), as `--energy`.
/// The file appears whole or not at all; a read-only file at `path` is refused unless
/// `force=True`. Returns `path`.
#[pyfunction]
#[pyo3(signature = (rig, path, model = "emulator", *, controller = "article", effects = true, energy = false, force = false))]
#[allow(clippy::too_many_arguments)]
fn fmu(
    py: Python<'_>,
    rig: Option<&PyRig>,
    path: PathBuf,
    model: &str,
    controller: &str,
    effects: bool,
    energy: bool,
    force: bool,
) -> PyResult<PathBuf> {
    use pumpcyl::fmu::{Controller, ModelKind};
    let model = match model {
        "emulator" => ModelKind::Emulator,
        "linear" => ModelKind::Linear,
        other => {
            return Err(err(format!(
                "model = {other:?}: \"emulator\" or \"linear\""
            )))
        }
    };
    if energy && model == ModelKind::Linear {
        return Err(err(
            "fmu(energy=True): the linear model has no power account; energy is the emulator's",
        ));
    }
    let controller = match controller {
        "article" => Controller::Article,
        "external" => Controller::External,
        other => {
            return Err(err(format!(
                "controller = {other:?}: \"article\" or \"external\""
            )))
        }
    };
    if path.extension().and_then(|e| e.to_str()) != Some("fmu") {
        return Err(err(format!(
            "path = {:?}: an FMU file name ends in .fmu",
            path.display().to_string()
        )));
    }
    let rig = match rig {
        Some(r) => r.rig.clone(),
        None => pumpcyl::fmu::default_rig(model, effects).map_err(err)?,
    };
    py.detach(|| -> Result<(), String> {
        let config = pumpcyl::fmu::checked_config((model, controller), effects, energy, rig)
            .map_err(|e| e.to_string())?;
        let bytes = pumpcyl_present::fmu::archive(&config).map_err(|e| format!("{e:#}"))?;
        pumpcyl_present::files::write_atomic(
            &path,
            &bytes,
            &pumpcyl_present::files::Protected::none().forcing(force),
        )
        .map_err(|e| format!("{e:#}"))
    })
    .map_err(err)?;
    Ok(path)
}

/// Which circuit, at which pressure level (docs/select.md): the application of the file
/// `application` (TOML; None = the article's application), with `overrides` as application
/// keys (`gas_fraction_max=0.1`, `low_pressure_bar=[2.0, 4.0]`) and `rig` replacing its rig
/// (as `--rig`: the gas fraction and the loads it leaves out follow the rig);
/// `kp` fixes the gain; `experiment` (an experiment TOML file) gives the gas-fraction range
/// from its records' interval of β at `confidence`. The command line's `select --json`, as a
/// `Result` (`column("options", "kp_max")`: a numpy array over the options). Loads × pressure
/// levels beyond 400 cases (each wave beyond the first adding 1/30 of a case), or single-pump
/// mode checks beyond 5e9 evaluations (docs/select.md#work), run only with
/// `allow_long_run=True`, as the command line's `--allow-long-run`. `progress` as for `identify`, over the load × level
/// cases. `mode_check` names the single-pump candidates' mode check, as the command line's
/// `--mode-check`: "emulator" (the default) or "equations". `circuits` names the circuits to
/// try (`["dpm", "valve"]`; default: the application's), as `--circuits`. A relief setting
/// that lets a one-motor circuit's chamber go above the cylinder's rating warns (UserWarning)
/// and is listed in `warnings`.
#[pyfunction]
#[pyo3(
    signature = (application = None, *, rig = None, circuits = vec![], kp = None, mode_check = "emulator", experiment = None, confidence = 0.95, allow_long_run = false, energy = false, progress = None, **overrides),
    text_signature = "(application=None, *, rig=None, circuits=(), kp=None, mode_check='emulator', \
        experiment=None, confidence=0.95, allow_long_run=False, energy=False, progress=None, **overrides)"
)]
#[allow(clippy::too_many_arguments)]
fn select(
    py: Python<'_>,
    application: Option<PathBuf>,
    rig: Option<&PyRig>,
    circuits: Vec<String>,
    kp: Option<f64>,
    mode_check: &str,
    experiment: Option<PathBuf>,
    confidence: f64,
    allow_long_run: bool,
    energy: bool,
    progress: Option<Py<PyAny>>,
    overrides: Option<&Bound<'_, PyDict>>,
) -> PyResult<PyOutcome> {
    use pumpcyl::select::Application;
    let base = match &application {
        Some(path) => Application::from_file_in(&pumpcyl::source_files::Disk, path).map_err(err)?,
        None => Application::default(),
    };
    let given = assignments("select", overrides)?;
    let all: Vec<String> = given.iter().map(|(.., a)| a.clone()).collect();
    // an override that does not fit names the keyword argument, `select(key=value): …`
    let mut app = base.with_overrides("select", &all).map_err(|e| match e {
        SelectError::Set {
            assignment,
            message,
            ..
        } => misfit("select", &given, &assignment, &message),
        SelectError::Invalid { key, message, .. } => err(format!(
            "{}: key `{key}`: {message}",
            concerned("select", &given, &key)
        )),
        other => err(other),
    })?;
    if let Some(r) = rig {
        let replaces = match app.rig_from {
            pumpcyl::select::RigFrom::Article => None,
            ref own => Some(own.describe()),
        };
        let from = pumpcyl::select::RigFrom::Given {
            name: "the `rig` argument".to_string(),
            replaces,
        };
        app = app.with_rig(r.rig.clone(), from).map_err(err)?;
    }
    let evidence = (experiment.as_deref())
        .map(|p| request::select::Evidence::new(confidence, || Ok(Experiment::load(p)?)))
        .transpose()
        .map_err(|e| request_err("select", &e))?;
    let request = request::select::Select {
        application: app,
        origin: (application.as_ref()).map_or("the article's application".into(), |p| {
            p.display().to_string()
        }),
        circuits,
        mode_check: mode_check.to_string(),
        kp,
        evidence,
        allow_long_run,
        energy,
    };
    let outcome = run_reporting(py, "select", &request, progress)?;
    document(py, "select", "Selection", &outcome)
}

/// Will it chatter (docs/circuits.md#a-scan-of-the-load; the article §2.1): the single-pump
/// rig's emulated 5 mm step, and each of `waves` ((freq_hz, amp_mm) pairs about x0), at each
/// external force, as `pumpcyl chatter --json`: `verdict` (`chatters`, `quiet`, or `no_modes`
/// for a circuit without modes, whose `answer` says why), `answer`, `switching_force_n`,
/// `valve_band_n`, `forces` (each force's switches, those after settling, those its waves'
/// references explain and the extra ones, its step and waves), `quiet_ranges_n`,
/// `chattering_ranges_n`. The forces: `forces_n` (a sequence, N), or `points` evenly from
/// `from_n` to `to_n`, or by default 13 over the valve band widened threefold about the
/// switching force (`points` alone changes their number). A scan beyond 10^7 emulated
/// controller steps runs only with `allow_long_run=True`, as `--allow-long-run`. `progress` as
/// for `identify`, over the emulated runs.
#[pyfunction]
#[pyo3(
    signature = (
        rig, *, forces_n = None, from_n = None, to_n = None, points = None, waves = vec![],
        allow_long_run = false, progress = None
    ),
    text_signature = "(rig, *, forces_n=None, from_n=None, to_n=None, points=None, waves=(), \
        allow_long_run=False, progress=None)"
)]
#[allow(clippy::too_many_arguments)]
fn chatter(
    py: Python<'_>,
    rig: &PyRig,
    forces_n: Option<Bound<'_, PyAny>>,
    from_n: Option<f64>,
    to_n: Option<f64>,
    points: Option<usize>,
    waves: Vec<(f64, f64)>,
    allow_long_run: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<PyOutcome> {
    use pumpcyl::emulator::chatter::{Forces, Wave, DEFAULT_POINTS};
    let forces = match (forces_n, from_n, to_n, points) {
        (Some(f), None, None, None) => {
            Some(Forces::Given(floats(&Arg::new("chatter", "forces_n"), &f)?))
        }
        (Some(_), ..) => {
            return Err(err(
                "chatter(forces_n=…): give the forces, or from_n, to_n and points, not both",
            ))
        }
        (None, Some(from_n), Some(to_n), points) => Some(Forces::Range {
            from_n,
            to_n,
            points: points.unwrap_or(DEFAULT_POINTS),
        }),
        (None, Some(_), None, _) | (None, None, Some(_), _) => {
            return Err(err(
                "chatter(from_n=…, to_n=…): give both ends of the range",
            ))
        }
        (None, None, None, Some(points)) => Some(Forces::AboutSwitching { points }),
        (None, None, None, None) => None,
    };
    let request = request::chatter::Chatter {
        rig: rig.input(),
        scan: pumpcyl_present::chatter::Request {
            forces,
            waves: (waves.iter())
                .map(|&(freq_hz, amplitude_mm)| Wave {
                    freq_hz,
                    amplitude_mm,
                })
                .collect(),
        },
        allow_long_run,
    };
    let outcome = run_reporting(py, "chatter", &request, progress)?;
    document(py, "chatter", "Chatter", &outcome)
}

/// A duty cycle on the emulated rig (docs/energy.md#duty-cycles), as `pumpcyl cycle --json`:
/// `cycle` "article-sines" (the article's three sines about x0), "steps" (`step_mm` about x0,
/// each level held `hold_s`) or a profile's file (`time_s`, `x_ref_mm`, optionally
/// `external_force_n`); `summary` (drawn, returned and net energy, the load's work, the
/// efficiency, mean and peak power), `energy` (the account by kind), `drives` (each motor's RMS
/// and peak torque and speed against its ratings, what it exceeds), `defaults_assumed` and
/// `columns`, the record with its power columns (numpy arrays). `rig` None: the emulated
/// article rig, as `emulate`. `progress` as for `identify`.
#[pyfunction]
#[pyo3(signature = (
    rig = None, cycle = "article-sines", *, step_mm = 20.0, hold_s = 2.0, seed = 1, noise = true,
    effects = true, allow_long_run = false, progress = None
))]
#[allow(clippy::too_many_arguments)]
fn cycle(
    py: Python<'_>,
    rig: Option<&PyRig>,
    cycle: &str,
    step_mm: f64,
    hold_s: f64,
    seed: u64,
    noise: bool,
    effects: bool,
    allow_long_run: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<PyOutcome> {
    use request::cycle::{CycleKind, CycleRequest};
    let (rig, name) = emulator_rig(rig, effects)?;
    let rig = RigInput {
        name,
        ..rig.input()
    };
    let cycle = CycleKind::named(cycle, step_mm, hold_s);
    let request = CycleRequest {
        rig,
        cycle,
        effects,
        noise,
        seed,
        allow_long_run,
        files: &pumpcyl::source_files::Disk,
    };
    let outcome = run_reporting(py, "cycle", &request, progress)?;
    document(py, "cycle", "DutyCycle", &outcome)?.with_arrays(py, "columns", "Columns")
}

/// The design method of the article (§2.2) for `rig` (default: the article's): the
/// largest Kp meeting the margin targets, margins across stroke, mass and pressure, predicted
/// tracking (each wave's periodic steady state: its `window.steady_state` is true,
/// docs/simulation.md#tracking-metrics) and a verdict; a dict as `pumpcyl design --json`
/// prints. The defaults are the
/// command line's (docs/design.md#targets): phase margin 34 deg (the article's result at Kp 25,
/// §3.3), gain margin 6 dB (pumpcyl's choice), x0 ± 50 mm of stroke (the article checks it,
/// §3.3), β identified at 4.4 bar; no `p_mean_bar` (bar) or `mass_kg` (kg) checks the rig's
/// β and mass only; `waves` are (freq_hz, amp_mm) pairs to track.
///
/// `robust=True` designs over the parameters' uncertainty (docs/design.md#robust-design), as
/// `pumpcyl design --robust --json`: over the confidence region (at `confidence`) of the
/// records of `experiment` (an experiment TOML file; its rig is designed, so `rig` must not be
/// given; without `p_mean_bar`, over the mean chamber pressures its records span), or without
/// `experiment` over the stated default uncertainty around `rig`.
///
/// Masses × pressures beyond 10^5 margin analyses (hours of work) run only with
/// `allow_long_run=True`, as the command line's `--allow-long-run`. `progress` as for
/// `identify`, over the design's conditions (the nominal design; the robust design reports
/// its end only). `sampled=True` designs on the loop as the rig's PLC closes it, as
/// `--sampled` (docs/analysis.md#sampled-data-margins). The result is a `Result`, the command line's `design --json` (or
/// `design --robust --json`).
#[pyfunction]
#[pyo3(
    signature = (
        rig = None, *, target_pm_deg = 34.0, target_gm_db = 6.0, stroke_mm = 50.0,
        p_mean_bar = vec![], p_beta_bar = None, mass_kg = vec![], waves = vec![], robust = false,
        experiment = None, confidence = 0.95, allow_long_run = false, progress = None,
        sampled = false
    ),
    text_signature = "(rig=None, *, target_pm_deg=34.0, target_gm_db=6.0, stroke_mm=50.0, \
        p_mean_bar=(), p_beta_bar=None, mass_kg=(), waves=(), robust=False, experiment=None, \
        confidence=0.95, allow_long_run=False, progress=None, sampled=False)"
)]
#[allow(clippy::too_many_arguments)]
fn design(
    py: Python<'_>,
    rig: Option<&PyRig>,
    target_pm_deg: f64,
    target_gm_db: f64,
    stroke_mm: f64,
    p_mean_bar: Vec<f64>,
    p_beta_bar: Option<f64>,
    mass_kg: Vec<f64>,
    waves: Vec<(f64, f64)>,
    robust: bool,
    experiment: Option<PathBuf>,
    confidence: f64,
    allow_long_run: bool,
    progress: Option<Py<PyAny>>,
    sampled: bool,
) -> PyResult<PyOutcome> {
    if experiment.is_some() && !robust {
        return Err(err("experiment: needs robust=True"));
    }
    if experiment.is_some() && rig.is_some() {
        return Err(err(
            "the rig comes from the experiment file: give either the file or rig",
        ));
    }
    let load = (experiment.as_deref()).map(|p| move || Ok(Experiment::load(p)?));
    let robust = (robust)
        .then(|| request::design::Robust::new(confidence, load))
        .transpose()
        .map_err(|e| request_err("design", &e))?;
    let request = request::design::Design {
        rig: rig.map_or_else(|| RigInput::default_named("Rig()"), PyRig::input),
        targets: pumpcyl::design::Targets {
            pm_deg: target_pm_deg,
            gm_db: target_gm_db,
            stroke_mm,
            p_mean_bar,
            p_beta_bar,
            mass_kg,
            waves,
            sampled,
            bulk_model: None,
        },
        allow_long_run,
        robust,
    };
    let kind = if request.robust.is_some() {
        "RobustDesign"
    } else {
        "Design"
    };
    let outcome = run_reporting(py, "design", &request, progress)?;
    document(py, "design", kind, &outcome)
}

#[pymodule]
fn _pumpcyl(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("PumpcylError", m.py().get_type::<PumpcylError>())?;
    m.add_class::<PyRig>()?;
    let rig_type = m.getattr("Rig")?;
    let own: String = rig_type.getattr("__doc__")?.extract()?;
    rig_type.setattr("__doc__", rig_doc(&own))?;
    m.add_class::<PyOutcome>()?;
    m.add_class::<PyDataset>()?;
    m.add_function(wrap_pyfunction!(margins, m)?)?;
    m.add_function(wrap_pyfunction!(poles, m)?)?;
    m.add_function(wrap_pyfunction!(state_space, m)?)?;
    m.add_function(wrap_pyfunction!(loop_names, m)?)?;
    m.add_function(wrap_pyfunction!(bode, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(step, m)?)?;
    m.add_function(wrap_pyfunction!(track, m)?)?;
    m.add_function(wrap_pyfunction!(identify, m)?)?;
    m.add_function(wrap_pyfunction!(identify_merge, m)?)?;
    m.add_function(wrap_pyfunction!(check_shards, m)?)?;
    m.add_function(wrap_pyfunction!(frf, m)?)?;
    m.add_function(wrap_pyfunction!(advise, m)?)?;
    m.add_function(wrap_pyfunction!(gas_fraction, m)?)?;
    m.add_function(wrap_pyfunction!(effective_beta, m)?)?;
    m.add_function(wrap_pyfunction!(design, m)?)?;
    m.add_function(wrap_pyfunction!(select, m)?)?;
    m.add_function(wrap_pyfunction!(chatter, m)?)?;
    m.add_function(wrap_pyfunction!(cycle, m)?)?;
    m.add_function(wrap_pyfunction!(fmu, m)?)?;
    m.add_function(wrap_pyfunction!(emulate, m)?)?;
    m.add_function(wrap_pyfunction!(reproduce, m)?)?;
    Ok(())
}
