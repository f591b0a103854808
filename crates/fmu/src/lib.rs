//! The FMI 2.0 Co-Simulation functions of pumpcyl's FMUs (docs/fmu.md): a thin C shell over
//! [`pumpcyl::fmu::Instance`]. Every function catches panics (a panic becomes `fmi2Error` with
//! a message through the logger, never an unwind across the C boundary), every instance owns
//! its state (no globals), and `fmi2FreeInstance` releases it.
//!
//! The functions follow the FMI 2.0.4 standard, section 2.1 (common) and 4.2
//! (Co-Simulation); functions the FMU does not support (FMU state, directional derivatives,
//! input derivatives, asynchronous steps) return `fmi2Error` with a logged reason, as the
//! capability flags of modelDescription.xml declare.

#![allow(clippy::missing_safety_doc)]

use pumpcyl::fmu::{Config, Instance, CONFIG_FILE};
use std::ffi::{c_char, c_int, c_void, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

type Status = c_int;
const OK: Status = 0;
const DISCARD: Status = 2;
const ERROR: Status = 3;

type Logger =
    unsafe extern "C" fn(*mut c_void, *const c_char, Status, *const c_char, *const c_char, ...);

/// fmi2CallbackFunctions.
#[repr(C)]
pub struct Callbacks {
    logger: Option<Logger>,
    allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    step_finished: Option<unsafe extern "C" fn(*mut c_void, Status)>,
    environment: *mut c_void,
}

/// One instance: the model and what it needs to report.
struct Component {
    name: CString,
    logger: Option<Logger>,
    environment: *mut c_void,
    fmu: Instance,
    start_s: f64,
    /// A previous error left the instance unusable.
    failed: bool,
}

impl Component {
    fn log(&self, status: Status, message: &str) {
        log(self.logger, self.environment, &self.name, status, message);
    }
}

/// Send `message` to the host's logger, if it gave one.
fn log(
    logger: Option<Logger>,
    environment: *mut c_void,
    name: &CStr,
    status: Status,
    message: &str,
) {
    if let Some(logger) = logger {
        let text = CString::new(message.replace('\0', " ")).unwrap_or_default();
        let category = if status >= ERROR {
            c"logStatusError"
        } else {
            c"logAll"
        };
        // SAFETY: the logger is the host's, called with valid C strings and a "%s" format
        unsafe {
            logger(
                environment,
                name.as_ptr(),
                status,
                category.as_ptr(),
                c"%s".as_ptr(),
                text.as_ptr(),
            )
        };
    }
}

/// Run `f` on the component, panics and errors turned into a logged `fmi2Error`.
unsafe fn with(
    c: *mut c_void,
    what: &str,
    f: impl FnOnce(&mut Component) -> Result<Status, String>,
) -> Status {
    if c.is_null() {
        return ERROR;
    }
    // SAFETY: the host passes back the pointer fmi2Instantiate returned
    let comp = unsafe { &mut *(c as *mut Component) };
    if comp.failed {
        comp.log(ERROR, &format!("{what}: the instance failed earlier"));
        return ERROR;
    }
    match catch_unwind(AssertUnwindSafe(|| f(comp))) {
        Ok(Ok(status)) => status,
        Ok(Err(message)) => {
            comp.log(ERROR, &format!("{what}: {message}"));
            ERROR
        }
        Err(panic) => {
            let why = panic
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| panic.downcast_ref::<&str>().copied())
                .unwrap_or("internal error");
            // the instance's state is unknown after a panic: it refuses every later call
            comp.failed = true;
            comp.log(
                ERROR,
                &format!("{what}: internal error ({why}); please report it"),
            );
            ERROR
        }
    }
}

/// The references and values of an array call, checked for null.
unsafe fn slices<'a, T>(
    vr: *const u32,
    nvr: usize,
    values: *const T,
) -> Result<(&'a [u32], &'a [T]), String> {
    if nvr == 0 {
        return Ok((&[], &[]));
    }
    if vr.is_null() || values.is_null() {
        return Err("null value reference or value array".into());
    }
    // SAFETY: the host guarantees nvr elements behind both pointers
    Ok(unsafe {
        (
            std::slice::from_raw_parts(vr, nvr),
            std::slice::from_raw_parts(values, nvr),
        )
    })
}

unsafe fn slices_mut<'a, T>(
    vr: *const u32,
    nvr: usize,
    values: *mut T,
) -> Result<(&'a [u32], &'a mut [T]), String> {
    if nvr == 0 {
        return Ok((&[], &mut []));
    }
    if vr.is_null() || values.is_null() {
        return Err("null value reference or value array".into());
    }
    // SAFETY: the host guarantees nvr elements behind both pointers
    Ok(unsafe {
        (
            std::slice::from_raw_parts(vr, nvr),
            std::slice::from_raw_parts_mut(values, nvr),
        )
    })
}

/// The folder a `file:` URI names (percent-decoded; `file:///p`, `file:/p`, `file://localhost/p`).
fn uri_path(uri: &str) -> Result<PathBuf, String> {
    let rest = uri
        .strip_prefix("file://localhost")
        .or_else(|| uri.strip_prefix("file://"))
        .or_else(|| uri.strip_prefix("file:"))
        .ok_or_else(|| format!("resource location `{uri}` is not a file: URI"))?;
    let bytes = rest.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            let hex = std::str::from_utf8(&bytes[i + 1..i + 3]).map_err(|e| e.to_string())?;
            out.push(u8::from_str_radix(hex, 16).map_err(|_| format!("bad escape in `{uri}`"))?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    Ok(PathBuf::from(
        String::from_utf8(out).map_err(|e| e.to_string())?,
    ))
}

/// Read the configuration from the resources and check the GUID.
fn load(resources: &str, guid: &str) -> Result<Instance, String> {
    let path = uri_path(resources)?.join(CONFIG_FILE);
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    let config = Config::from_toml(&text).map_err(|e| e.to_string())?;
    if config.guid != guid {
        return Err(format!(
            "GUID {guid} does not match the FMU's {} (modelDescription.xml and {CONFIG_FILE} differ)",
            config.guid
        ));
    }
    Instance::new(config).map_err(|e| e.to_string())
}

unsafe fn text(p: *const c_char) -> String {
    if p.is_null() {
        String::new()
    } else {
        // SAFETY: a non-null C string from the host
        unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
    }
}

#[no_mangle]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}

#[no_mangle]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    c"2.0".as_ptr()
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Instantiate(
    name: *const c_char,
    kind: c_int,
    guid: *const c_char,
    resources: *const c_char,
    callbacks: *const Callbacks,
    _visible: c_int,
    _logging_on: c_int,
) -> *mut c_void {
    let result = catch_unwind(|| {
        // SAFETY: strings and callbacks from the host, checked for null
        let (name, guid, resources) = unsafe { (text(name), text(guid), text(resources)) };
        let (logger, environment) = if callbacks.is_null() {
            (None, std::ptr::null_mut())
        } else {
            // SAFETY: a non-null callback structure from the host
            let cb = unsafe { &*callbacks };
            (cb.logger, cb.environment)
        };
        let name = CString::new(name.replace('\0', " ")).unwrap_or_default();
        let loaded = if kind == 1 {
            load(&resources, &guid)
        } else {
            Err("this FMU supports Co-Simulation only".into())
        };
        match loaded {
            Ok(fmu) => Some(Box::into_raw(Box::new(Component {
                name,
                logger,
                environment,
                fmu,
                start_s: 0.0,
                failed: false,
            })) as *mut c_void),
            Err(e) => {
                log(
                    logger,
                    environment,
                    &name,
                    ERROR,
                    &format!("fmi2Instantiate: {e}"),
                );
                None
            }
        }
    });
    match result {
        Ok(Some(p)) => p,
        _ => std::ptr::null_mut(),
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2FreeInstance(c: *mut c_void) {
    if !c.is_null() {
        // SAFETY: the pointer fmi2Instantiate returned, freed once by the host
        let _ = catch_unwind(|| drop(unsafe { Box::from_raw(c as *mut Component) }));
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetDebugLogging(
    c: *mut c_void,
    _on: c_int,
    _n: usize,
    _categories: *const *const c_char,
) -> Status {
    unsafe { with(c, "fmi2SetDebugLogging", |_| Ok(OK)) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetupExperiment(
    c: *mut c_void,
    _tolerance_defined: c_int,
    _tolerance: f64,
    start_s: f64,
    _stop_defined: c_int,
    _stop_s: f64,
) -> Status {
    unsafe {
        with(c, "fmi2SetupExperiment", |comp| {
            comp.start_s = start_s;
            Ok(OK)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2EnterInitializationMode(c: *mut c_void) -> Status {
    unsafe { with(c, "fmi2EnterInitializationMode", |_| Ok(OK)) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2ExitInitializationMode(c: *mut c_void) -> Status {
    unsafe {
        with(c, "fmi2ExitInitializationMode", |comp| {
            let start = comp.start_s;
            comp.fmu.initialize(start).map_err(|e| e.to_string())?;
            Ok(OK)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Terminate(c: *mut c_void) -> Status {
    unsafe { with(c, "fmi2Terminate", |_| Ok(OK)) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Reset(c: *mut c_void) -> Status {
    unsafe {
        with(c, "fmi2Reset", |comp| {
            comp.fmu = Instance::new(comp.fmu.config().clone()).map_err(|e| e.to_string())?;
            Ok(OK)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetReal(
    c: *mut c_void,
    vr: *const u32,
    n: usize,
    values: *mut f64,
) -> Status {
    unsafe {
        with(c, "fmi2GetReal", |comp| {
            let (vr, values) = slices_mut(vr, n, values)?;
            for (r, v) in vr.iter().zip(values.iter_mut()) {
                *v = comp.fmu.get_real(*r).map_err(|e| e.to_string())?;
            }
            Ok(OK)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetReal(
    c: *mut c_void,
    vr: *const u32,
    n: usize,
    values: *const f64,
) -> Status {
    unsafe {
        with(c, "fmi2SetReal", |comp| {
            let (vr, values) = slices(vr, n, values)?;
            for (r, v) in vr.iter().zip(values) {
                comp.fmu.set_real(*r, *v).map_err(|e| e.to_string())?;
            }
            Ok(OK)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetBoolean(
    c: *mut c_void,
    vr: *const u32,
    n: usize,
    values: *mut c_int,
) -> Status {
    unsafe {
        with(c, "fmi2GetBoolean", |comp| {
            let (vr, values) = slices_mut(vr, n, values)?;
            for (r, v) in vr.iter().zip(values.iter_mut()) {
                *v = c_int::from(comp.fmu.get_boolean(*r).map_err(|e| e.to_string())?);
            }
            Ok(OK)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetBoolean(
    c: *mut c_void,
    vr: *const u32,
    n: usize,
    values: *const c_int,
) -> Status {
    unsafe {
        with(c, "fmi2SetBoolean", |comp| {
            let (vr, values) = slices(vr, n, values)?;
            for (r, v) in vr.iter().zip(values) {
                comp.fmu
                    .set_boolean(*r, *v != 0)
                    .map_err(|e| e.to_string())?;
            }
            Ok(OK)
        })
    }
}

/// Integer and String variables: the FMU has none.
unsafe fn none_of_type(c: *mut c_void, what: &str, n: usize) -> Status {
    unsafe {
        with(c, what, |_| {
            if n == 0 {
                Ok(OK)
            } else {
                Err("this FMU has no variables of that type".into())
            }
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetInteger(
    c: *mut c_void,
    _vr: *const u32,
    n: usize,
    _v: *mut c_int,
) -> Status {
    unsafe { none_of_type(c, "fmi2GetInteger", n) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetInteger(
    c: *mut c_void,
    _vr: *const u32,
    n: usize,
    _v: *const c_int,
) -> Status {
    unsafe { none_of_type(c, "fmi2SetInteger", n) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetString(
    c: *mut c_void,
    _vr: *const u32,
    n: usize,
    _v: *mut *const c_char,
) -> Status {
    unsafe { none_of_type(c, "fmi2GetString", n) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetString(
    c: *mut c_void,
    _vr: *const u32,
    n: usize,
    _v: *const *const c_char,
) -> Status {
    unsafe { none_of_type(c, "fmi2SetString", n) }
}

/// A capability the FMU does not declare.
unsafe fn unsupported(c: *mut c_void, what: &str) -> Status {
    unsafe {
        with(c, what, |_| {
            Err("not supported by this FMU (see modelDescription.xml)".into())
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetFMUstate(c: *mut c_void, _s: *mut *mut c_void) -> Status {
    unsafe { unsupported(c, "fmi2GetFMUstate") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetFMUstate(c: *mut c_void, _s: *mut c_void) -> Status {
    unsafe { unsupported(c, "fmi2SetFMUstate") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2FreeFMUstate(c: *mut c_void, _s: *mut *mut c_void) -> Status {
    unsafe { unsupported(c, "fmi2FreeFMUstate") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
    c: *mut c_void,
    _s: *mut c_void,
    _n: *mut usize,
) -> Status {
    unsafe { unsupported(c, "fmi2SerializedFMUstateSize") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SerializeFMUstate(
    c: *mut c_void,
    _s: *mut c_void,
    _b: *mut c_char,
    _n: usize,
) -> Status {
    unsafe { unsupported(c, "fmi2SerializeFMUstate") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
    c: *mut c_void,
    _b: *const c_char,
    _n: usize,
    _s: *mut *mut c_void,
) -> Status {
    unsafe { unsupported(c, "fmi2DeSerializeFMUstate") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
    c: *mut c_void,
    _u: *const u32,
    _nu: usize,
    _z: *const u32,
    _nz: usize,
    _dv: *const f64,
    _dz: *mut f64,
) -> Status {
    unsafe { unsupported(c, "fmi2GetDirectionalDerivative") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
    c: *mut c_void,
    _vr: *const u32,
    _n: usize,
    _o: *const c_int,
    _v: *const f64,
) -> Status {
    unsafe { unsupported(c, "fmi2SetRealInputDerivatives") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
    c: *mut c_void,
    _vr: *const u32,
    _n: usize,
    _o: *const c_int,
    _v: *mut f64,
) -> Status {
    unsafe { unsupported(c, "fmi2GetRealOutputDerivatives") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2DoStep(
    c: *mut c_void,
    t: f64,
    h: f64,
    _no_set_prior: c_int,
) -> Status {
    unsafe {
        with(c, "fmi2DoStep", |comp| {
            comp.fmu.do_step(t, h).map_err(|e| e.to_string())?;
            Ok(OK)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2CancelStep(c: *mut c_void) -> Status {
    unsafe { unsupported(c, "fmi2CancelStep") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetStatus(c: *mut c_void, _k: c_int, _v: *mut Status) -> Status {
    unsafe { with(c, "fmi2GetStatus", |_| Ok(DISCARD)) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealStatus(c: *mut c_void, _k: c_int, _v: *mut f64) -> Status {
    unsafe { with(c, "fmi2GetRealStatus", |_| Ok(DISCARD)) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetIntegerStatus(c: *mut c_void, _k: c_int, _v: *mut c_int) -> Status {
    unsafe { with(c, "fmi2GetIntegerStatus", |_| Ok(DISCARD)) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetBooleanStatus(c: *mut c_void, _k: c_int, _v: *mut c_int) -> Status {
    unsafe { with(c, "fmi2GetBooleanStatus", |_| Ok(DISCARD)) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetStringStatus(
    c: *mut c_void,
    _k: c_int,
    _v: *mut *const c_char,
) -> Status {
    unsafe { with(c, "fmi2GetStringStatus", |_| Ok(DISCARD)) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_uris_name_their_folder() {
        assert_eq!(
            uri_path("file:///tmp/a%20b/resources").unwrap(),
            PathBuf::from("/tmp/a b/resources")
        );
        assert_eq!(uri_path("file:/tmp/x").unwrap(), PathBuf::from("/tmp/x"));
        assert_eq!(
            uri_path("file://localhost/tmp/x/").unwrap(),
            PathBuf::from("/tmp/x/")
        );
        assert!(uri_path("http://example.org/x").is_err());
    }
}
